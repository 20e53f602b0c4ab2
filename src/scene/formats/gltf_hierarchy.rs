//! The glTF node hierarchy checked before any traversal: no node may be its own ancestor, and
//! no scene may expand to more node instances than [`MAX_NODE_VISITS`].
//!
//! glTF requires the nodes to form disjoint trees. Files that reuse a node under several
//! parents (a DAG) are accepted, as other loaders accept them, but their expansion is counted
//! first: a few kilobytes of nodes each listing the next twice would otherwise expand to
//! billions of mesh instances, and a cycle to as many as the traversal allows.

use std::path::Path;

use super::gltf_mesh::MAX_NODE_VISITS;
use super::LoadError;

/// Refuses a node hierarchy with a cycle, or whose scenes (or parentless nodes, for files
/// without scenes) expand to more than [`MAX_NODE_VISITS`] node instances.
pub(crate) fn check_hierarchy(path: &Path, document: &gltf::Document) -> Result<(), LoadError> {
    let children: Vec<Vec<usize>> = document
        .nodes()
        .map(|n| n.children().map(|c| c.index()).collect())
        .collect();
    let instances = subtree_instances(&children).map_err(|node| {
        LoadError::parse(
            path,
            format!("nodes[{node}]: the node is its own ancestor (a cyclic hierarchy)"),
        )
    })?;
    let too_many = |what: String| {
        LoadError::parse(
            path,
            format!("{what} expands to more than {MAX_NODE_VISITS} node instances"),
        )
    };
    for scene in document.scenes() {
        if expansion(&instances, scene.nodes().map(|n| n.index())) > MAX_NODE_VISITS {
            return Err(too_many(format!("scenes[{}]", scene.index())));
        }
    }
    let has_parent = has_parent(document);
    let roots = (0..children.len()).filter(|&n| !has_parent[n]);
    if expansion(&instances, roots) > MAX_NODE_VISITS {
        return Err(too_many("the node hierarchy".into()));
    }
    Ok(())
}

/// For every node, whether another node lists it as a child (the roots of a file without
/// scenes are the nodes without a parent).
pub(crate) fn has_parent(document: &gltf::Document) -> Vec<bool> {
    let mut has_parent = vec![false; document.nodes().len()];
    for c in document.nodes().flat_map(|n| n.children()) {
        if let Some(flag) = has_parent.get_mut(c.index()) {
            *flag = true;
        }
    }
    has_parent
}

/// How many node instances `roots` expand to, saturating.
fn expansion(instances: &[usize], roots: impl Iterator<Item = usize>) -> usize {
    roots.fold(0usize, |sum, n| {
        sum.saturating_add(instances.get(n).copied().unwrap_or(0))
    })
}

/// For every node, how many node instances its subtree expands to (itself and its
/// descendants, a node reached along two paths counted twice), saturating above
/// [`MAX_NODE_VISITS`]. A cycle is an error naming a node on it. Iterative: a chain of a
/// million nodes does not overflow the stack.
fn subtree_instances(children: &[Vec<usize>]) -> Result<Vec<usize>, usize> {
    const NEW: u8 = 0;
    const OPEN: u8 = 1;
    const DONE: u8 = 2;
    let mut state = vec![NEW; children.len()];
    let mut instances = vec![0usize; children.len()];
    for start in 0..children.len() {
        if state[start] != NEW {
            continue;
        }
        // (node, index of the next child to visit)
        let mut stack = vec![(start, 0usize)];
        state[start] = OPEN;
        while let Some(&(node, next)) = stack.last() {
            match children[node].get(next) {
                Some(&child) => {
                    if let Some(top) = stack.last_mut() {
                        top.1 += 1;
                    }
                    match state.get(child) {
                        Some(&NEW) => {
                            state[child] = OPEN;
                            stack.push((child, 0));
                        }
                        Some(&OPEN) => return Err(child),
                        // Done, or out of range (the gltf crate's validation refuses that).
                        _ => {}
                    }
                }
                None => {
                    let sum = children[node].iter().fold(1usize, |sum, &c| {
                        sum.saturating_add(instances.get(c).copied().unwrap_or(0))
                    });
                    instances[node] = sum.min(MAX_NODE_VISITS + 1);
                    state[node] = DONE;
                    stack.pop();
                }
            }
        }
    }
    Ok(instances)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trees_count_their_nodes_and_shared_nodes_count_once_per_path() {
        // 0 -> {1, 2}, 1 -> {3}, 2 -> {3}: node 3 is reached along two paths.
        let children = vec![vec![1, 2], vec![3], vec![3], vec![]];
        assert_eq!(subtree_instances(&children), Ok(vec![5, 2, 2, 1]));
    }

    #[test]
    fn a_cycle_names_a_node_on_it() {
        assert_eq!(subtree_instances(&[vec![0]]), Err(0));
        // 0 -> 1 -> 2 -> 1
        assert_eq!(subtree_instances(&[vec![1], vec![2], vec![1]]), Err(1));
    }

    #[test]
    fn doubling_chains_saturate_and_deep_chains_do_not_overflow_the_stack() {
        // Node i lists node i + 1 twice: 2^64 instances at the top, counted as "too many".
        let mut children: Vec<Vec<usize>> = (0..64).map(|i| vec![i + 1, i + 1]).collect();
        children.push(Vec::new());
        let instances = subtree_instances(&children).unwrap();
        assert_eq!(instances[64], 1);
        assert_eq!(instances[60], 31);
        assert_eq!(instances[0], MAX_NODE_VISITS + 1);

        let chain: Vec<Vec<usize>> = (0..200_000)
            .map(|i| {
                if i + 1 < 200_000 {
                    vec![i + 1]
                } else {
                    Vec::new()
                }
            })
            .collect();
        assert_eq!(subtree_instances(&chain).unwrap()[0], 200_000);
    }

    fn document(nodes: &str, scenes: &str) -> gltf::Document {
        let json =
            format!(r#"{{"asset": {{"version": "2.0"}}, "nodes": {nodes}, "scenes": {scenes}}}"#);
        let root: gltf::json::Root = serde_json::from_str(&json).unwrap();
        gltf::Document::from_json_without_validation(root)
    }

    #[test]
    fn files_with_cycles_or_huge_expansions_are_refused_naming_the_file() {
        let path = Path::new("x.glb");
        let ok = document(r#"[{"children": [1]}, {}]"#, r#"[{"nodes": [0]}]"#);
        assert!(check_hierarchy(path, &ok).is_ok());

        let cyclic = document(
            r#"[{"children": [1]}, {"children": [1]}]"#,
            r#"[{"nodes": [0]}]"#,
        );
        let e = check_hierarchy(path, &cyclic).unwrap_err().to_string();
        assert!(
            e.contains("x.glb") && e.contains("nodes[1]: the node is its own ancestor"),
            "{e}"
        );

        // 24 doublings: 2^25 - 1 instances from a 25-node file.
        let nodes: Vec<String> = (0..25)
            .map(|i| {
                if i < 24 {
                    format!(r#"{{"children": [{0}, {0}]}}"#, i + 1)
                } else {
                    "{}".into()
                }
            })
            .collect();
        let huge = document(&format!("[{}]", nodes.join(",")), r#"[{"nodes": [0]}]"#);
        let e = check_hierarchy(path, &huge).unwrap_err().to_string();
        assert!(
            e.contains("scenes[0] expands to more than 1000000 node instances"),
            "{e}"
        );
        // Without scenes, the parentless nodes are the roots.
        let huge = document(&format!("[{}]", nodes.join(",")), "[]");
        let e = check_hierarchy(path, &huge).unwrap_err().to_string();
        assert!(e.contains("the node hierarchy expands to more"), "{e}");
    }
}
