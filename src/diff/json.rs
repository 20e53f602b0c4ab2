//! The first difference of two JSON documents, by its path (`groups.all.success`,
//! `episodes[3].metrics.spl`).

use serde_json::Value;

use super::quote;

/// `path: A vs B` for the first value that differs, `None` when either is not JSON or they
/// are equal as values (then only their layout differs, which the caller reports by bytes).
pub(super) fn first_difference(a: &[u8], b: &[u8]) -> Option<String> {
    let va: Value = serde_json::from_slice(a).ok()?;
    let vb: Value = serde_json::from_slice(b).ok()?;
    let mut path = String::new();
    walk(&va, &vb, &mut path)
}

fn show(v: Option<&Value>) -> String {
    v.map_or("(absent)".into(), |v| quote(&v.to_string()))
}

fn walk(a: &Value, b: &Value, path: &mut String) -> Option<String> {
    if a == b {
        return None;
    }
    let here = |p: &str| {
        if p.is_empty() {
            "(top)".to_string()
        } else {
            p.to_string()
        }
    };
    match (a, b) {
        (Value::Object(ma), Value::Object(mb)) => {
            let keys: std::collections::BTreeSet<&String> = ma.keys().chain(mb.keys()).collect();
            for k in keys {
                let len = path.len();
                if !path.is_empty() {
                    path.push('.');
                }
                path.push_str(k);
                let found = match (ma.get(k), mb.get(k)) {
                    (Some(x), Some(y)) => walk(x, y, path),
                    (x, y) => Some(format!("`{path}`: {} vs {}", show(x), show(y))),
                };
                path.truncate(len);
                if found.is_some() {
                    return found;
                }
            }
            None
        }
        (Value::Array(xa), Value::Array(xb)) => {
            for i in 0..xa.len().max(xb.len()) {
                let len = path.len();
                path.push_str(&format!("[{i}]"));
                let found = match (xa.get(i), xb.get(i)) {
                    (Some(x), Some(y)) => walk(x, y, path),
                    (x, y) => Some(format!("`{path}`: {} vs {}", show(x), show(y))),
                };
                path.truncate(len);
                if found.is_some() {
                    return found;
                }
            }
            None
        }
        _ => Some(format!(
            "`{}`: {} vs {}",
            here(path),
            show(Some(a)),
            show(Some(b))
        )),
    }
}
