//! Wavefront OBJ + MTL writer.
//!
//! One `o`/`g` pair per part, world positions (`v`), UVs where the mesh has them (`vt`), world
//! normals (`vn`), and faces grouped by material (`usemtl`). The MTL is written first, so an
//! `.obj` under its final name always finds its material library.

use std::io::Write;
use std::path::Path;

use super::{Counter, ExportError, ExportSummary, Plan};
use crate::atomic::write_atomic;
use crate::scene::Scene;

/// Writes `plan` to `out` and its materials to `out` with the extension `.mtl`.
pub(super) fn write(scene: &Scene, plan: &Plan, out: &Path) -> Result<ExportSummary, ExportError> {
    let mtl_path = out.with_extension("mtl");
    if mtl_path == out {
        return Err(ExportError::invalid(
            out,
            "an OBJ export cannot be named .mtl (its material library takes that name)",
        ));
    }
    let mtl_name = mtl_path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .ok_or_else(|| ExportError::invalid(out, "not a file name"))?;

    let mtl_bytes = write_atomic(&mtl_path, |w| {
        let mut w = Counter::new(w);
        write_mtl(&mut w, scene, plan)?;
        Ok(w.bytes)
    })
    .map_err(ExportError::io(&mtl_path))?;

    let (mut summary, obj_bytes) = write_atomic(out, |w| {
        let mut w = Counter::new(w);
        let summary = write_obj(&mut w, scene, plan, &mtl_name)?;
        Ok((summary, w.bytes))
    })
    .map_err(ExportError::io(out))?;

    summary.bytes = obj_bytes + mtl_bytes;
    summary.files = vec![out.to_path_buf(), mtl_path];
    Ok(summary)
}

/// The material library: `Kd`, `d` below 1, and the texture name as a comment.
fn write_mtl(w: &mut impl Write, scene: &Scene, plan: &Plan) -> std::io::Result<()> {
    writeln!(
        w,
        "# minos export of scene {}: diffuse colours only (textures are not exported)",
        one_line(&scene.id)
    )?;
    writeln!(w, "# {} materials", plan.materials.len())?;
    for m in &plan.materials {
        let [r, g, b, a] = m.diffuse;
        writeln!(w, "\nnewmtl {}", m.name)?;
        writeln!(w, "Ka 0 0 0")?;
        writeln!(w, "Kd {r} {g} {b}")?;
        writeln!(w, "Ks 0 0 0")?;
        if a < 1.0 {
            writeln!(w, "d {a}")?;
        }
        writeln!(w, "illum 1")?;
        if let Some(t) = &m.texture {
            writeln!(w, "# map_Kd {}", one_line(t))?;
        }
    }
    Ok(())
}

/// The geometry; returns the counts (bytes and files are filled in by the caller).
fn write_obj(
    w: &mut impl Write,
    scene: &Scene,
    plan: &Plan,
    mtl_name: &str,
) -> std::io::Result<ExportSummary> {
    writeln!(
        w,
        "# minos export of scene {} ({}): world space, y up, metres",
        one_line(&scene.id),
        scene.dataset.name()
    )?;
    writeln!(w, "mtllib {mtl_name}")?;
    let mut summary = ExportSummary::default();
    // 1-based index of the first vertex / uv / normal of the next part.
    let (mut v_base, mut vt_base, mut vn_base) = (1u64, 1u64, 1u64);
    for part in &plan.parts {
        let Some(world) = part.world(scene) else {
            summary.skipped.push(part.warn_skipped());
            continue;
        };
        writeln!(w, "o {}", part.name)?;
        writeln!(w, "g {}", part.name)?;
        for p in &world.positions {
            writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
        }
        let uvs = part.uvs();
        for uv in uvs.unwrap_or_default() {
            writeln!(w, "vt {} {}", uv[0], uv[1])?;
        }
        for n in &world.normals {
            writeln!(w, "vn {} {} {}", n.x, n.y, n.z)?;
        }
        let has_normals = world.normals.len() == world.positions.len();
        for (&(_, mat), tris) in part.slots.iter().zip(part.triangles_by_slot(&world)) {
            if tris.is_empty() {
                continue;
            }
            let name = plan
                .materials
                .get(mat)
                .map_or("default", |m| m.name.as_str());
            writeln!(w, "usemtl {name}")?;
            for tri in tris.chunks_exact(3) {
                w.write_all(b"f")?;
                for &i in tri {
                    let i = u64::from(i);
                    let v = v_base + i;
                    match (uvs.is_some(), has_normals) {
                        (true, true) => write!(w, " {v}/{}/{}", vt_base + i, vn_base + i)?,
                        (false, true) => write!(w, " {v}//{}", vn_base + i)?,
                        (true, false) => write!(w, " {v}/{}", vt_base + i)?,
                        (false, false) => write!(w, " {v}")?,
                    }
                }
                w.write_all(b"\n")?;
                summary.triangles += 1;
            }
        }
        v_base += world.positions.len() as u64;
        vt_base += uvs.map_or(0, |u| u.len() as u64);
        vn_base += world.normals.len() as u64;
        summary.nodes += 1;
    }
    Ok(summary)
}

/// `s` with line breaks and other control characters replaced, for comments.
fn one_line(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect()
}
