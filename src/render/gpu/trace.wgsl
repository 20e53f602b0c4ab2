// minos's GPU ray tracer: one invocation per pixel of one view, 8×8 pixels per workgroup,
// one workgroup layer per view. Each ray traverses the same four-wide BVH the CPU ray caster
// builds (`render/bvh`, flattened by `Bvh::flat_nodes` / `flat_leaves`), nearest child first,
// with the watertight ray–triangle test, and writes the nearest triangle's id (ties to the
// lowest id) and its depth-buffer value, as the CPU ray caster does.

struct Node {
    // bounds[side * 3 + axis]: side 0 the children's minima, 1 their maxima; lane = child.
    bounds: array<vec4<f32>, 6>,
    child: vec4<u32>,
    // 0: inner node; 1-4: a leaf's triangles; EMPTY: an unused slot.
    count: vec4<u32>,
};

struct Leaf {
    // corners[3 * corner + axis]: lane i is triangle i's coordinate.
    corners: array<vec4<f32>, 9>,
    ids: vec4<u32>,
};

struct View {
    // xyz: camera position.
    origin: vec4<f32>,
    // xyz: world right, up and viewing direction of the camera.
    right: vec4<f32>,
    up: vec4<f32>,
    forward: vec4<f32>,
    // near, far, tan(vfov / 2), aspect.
    lens: vec4<f32>,
    // The projection's depth row: z_clip = a·z_view + b (x: a, y: b).
    depth: vec4<f32>,
    // x: the view's place in the batch (its output slot).
    slot: vec4<u32>,
};

struct Batch {
    // First view of this dispatch, views in the whole batch, image width and height.
    first: u32,
    total: u32,
    width: u32,
    height: u32,
    // Where the per-view overflow flags start in `out` (a view's word is set to 1 when any
    // of its rays overflowed; the host clears them before the pass).
    flags: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
};

const EMPTY: u32 = 0xffffffffu;
const NO_HIT: u32 = 0xffffffffu;
// A ray whose traversal stack overflowed: the host casts that view again on the CPU.
const OVERFLOW: u32 = 0xfffffffeu;
const STACK: u32 = 64u;

@group(0) @binding(0) var<storage, read> nodes: array<Node>;
@group(0) @binding(1) var<storage, read> leaves: array<Leaf>;
@group(1) @binding(0) var<storage, read> views: array<View>;
@group(1) @binding(1) var<storage, read_write> out: array<u32>;
@group(1) @binding(2) var<uniform> batch: Batch;

fn safe(d: f32) -> f32 {
    if abs(d) < 1e-20 {
        return select(1e-20, -1e-20, d < 0.0);
    }
    return d;
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let w = batch.width;
    let h = batch.height;
    if gid.x >= w || gid.y >= h {
        return;
    }
    let view = views[batch.first + gid.z];
    // The pixel centre's ray, as `PixelRays` computes it: the component along the viewing
    // axis is 1, so the ray parameter is camera-space depth.
    let tan = view.lens.z;
    let aspect = view.lens.w;
    let sx_px = ((f32(gid.x) + 0.5) / f32(w) * 2.0 - 1.0) * tan * aspect;
    let sy_px = (1.0 - (f32(gid.y) + 0.5) / f32(h) * 2.0) * tan;
    let dir = view.right.xyz * sx_px + (view.forward.xyz + view.up.xyz * sy_px);
    let o = view.origin.xyz;
    let t_min = view.lens.x;

    let inv = vec3<f32>(1.0 / safe(dir.x), 1.0 / safe(dir.y), 1.0 / safe(dir.z));
    let oi = o * inv;
    // Where each axis's near and far box sides are in a node's bounds (side * 3 + axis).
    let nx = select(0u, 3u, inv.x < 0.0);
    let ny = select(1u, 4u, inv.y < 0.0);
    let nz = select(2u, 5u, inv.z < 0.0);
    let fx = 3u - nx;
    let fy = 5u - ny;
    let fz = 7u - nz;
    // Watertight test (Woop, Benthin and Wald 2013): the largest direction axis becomes z.
    let ad = abs(dir);
    var kz = 2u;
    if ad.x >= ad.y && ad.x >= ad.z {
        kz = 0u;
    } else if ad.y >= ad.z {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kz + 2u) % 3u;
    if dir[kz] < 0.0 {
        let s = kx;
        kx = ky;
        ky = s;
    }
    let shx = dir[kx] / dir[kz];
    let shy = dir[ky] / dir[kz];
    let shz = 1.0 / dir[kz];
    let okx = o[kx];
    let oky = o[ky];
    let okz = o[kz];

    var best_t = view.lens.y;
    var best_tri = NO_HIT;
    var stack_entry: array<u32, STACK>;
    var stack_t: array<f32, STACK>;
    var top = 0u;
    var overflow = false;
    // The node or leaf being visited: (index << 3) | count, count 0 for an inner node.
    var at = 0u;
    var visiting = true;
    loop {
        if visiting {
            let count = at & 7u;
            let index = at >> 3u;
            if count == 0u {
                // Read straight from the buffer: a dynamically indexed copy would live in
                // slow per-invocation memory.
                let near = max(max(max(nodes[index].bounds[nx] * inv.x - oi.x,
                                       nodes[index].bounds[ny] * inv.y - oi.y),
                                   nodes[index].bounds[nz] * inv.z - oi.z), vec4<f32>(t_min));
                let far = min(min(min(nodes[index].bounds[fx] * inv.x - oi.x,
                                      nodes[index].bounds[fy] * inv.y - oi.y),
                                  nodes[index].bounds[fz] * inv.z - oi.z), vec4<f32>(best_t));
                let counts = nodes[index].count;
                let children = nodes[index].child;
                let hit = (near <= far) & (counts != vec4<u32>(EMPTY));
                var next = 0u;
                var next_t = 0.0;
                var found = false;
                let base = top;
                for (var k = 0u; k < 4u; k++) {
                    if !hit[k] {
                        continue;
                    }
                    var e = (children[k] << 3u) | counts[k];
                    var et = near[k];
                    if !found {
                        next = e;
                        next_t = et;
                        found = true;
                        continue;
                    }
                    if et < next_t {
                        let s = e;
                        e = next;
                        next = s;
                        let st = et;
                        et = next_t;
                        next_t = st;
                    }
                    if top == STACK {
                        overflow = true;
                        break;
                    }
                    // Farthest deepest: insert above this node's farther entries.
                    var i = top;
                    while i > base && stack_t[i - 1u] < et {
                        stack_entry[i] = stack_entry[i - 1u];
                        stack_t[i] = stack_t[i - 1u];
                        i -= 1u;
                    }
                    stack_entry[i] = e;
                    stack_t[i] = et;
                    top += 1u;
                }
                if overflow {
                    break;
                }
                if found {
                    at = next;
                    continue;
                }
            } else {
                var ax: vec4<f32>;
                var ay: vec4<f32>;
                var az: vec4<f32>;
                var bx: vec4<f32>;
                var by: vec4<f32>;
                var bz: vec4<f32>;
                var cx: vec4<f32>;
                var cy: vec4<f32>;
                var cz: vec4<f32>;
                {
                    let px = leaves[index].corners[kx] - okx;
                    let py = leaves[index].corners[ky] - oky;
                    let pz = leaves[index].corners[kz] - okz;
                    ax = px - shx * pz;
                    ay = py - shy * pz;
                    az = shz * pz;
                }
                {
                    let px = leaves[index].corners[3u + kx] - okx;
                    let py = leaves[index].corners[3u + ky] - oky;
                    let pz = leaves[index].corners[3u + kz] - okz;
                    bx = px - shx * pz;
                    by = py - shy * pz;
                    bz = shz * pz;
                }
                {
                    let px = leaves[index].corners[6u + kx] - okx;
                    let py = leaves[index].corners[6u + ky] - oky;
                    let pz = leaves[index].corners[6u + kz] - okz;
                    cx = px - shx * pz;
                    cy = py - shy * pz;
                    cz = shz * pz;
                }
                let u = cx * by - cy * bx;
                let v = ax * cy - ay * cx;
                let ww = bx * ay - by * ax;
                let zero = vec4<f32>(0.0);
                let outside = ((u < zero) | (v < zero) | (ww < zero)) & ((u > zero) | (v > zero) | (ww > zero));
                let det = u + v + ww;
                let t = (u * az + v * bz + ww * cz) / det;
                let met = !outside & (det != zero) & (t >= vec4<f32>(t_min));
                for (var k = 0u; k < 4u; k++) {
                    let id = leaves[index].ids[k];
                    if met[k] && (t[k] < best_t || (t[k] == best_t && id < best_tri)) {
                        best_t = t[k];
                        best_tri = id;
                    }
                }
            }
            visiting = false;
        }
        // Next: the nearest pushed entry the ray may still reach before its best hit.
        if top == 0u {
            break;
        }
        top -= 1u;
        if stack_t[top] <= best_t {
            at = stack_entry[top];
            visiting = true;
        }
    }

    let pixels = w * h;
    let slot = view.slot.x;
    let p = slot * pixels + gid.y * w + gid.x;
    if overflow {
        // Every overflowing invocation of the view stores the same 1.
        out[batch.flags + slot] = 1u;
        out[p] = OVERFLOW;
        out[batch.total * pixels + p] = bitcast<u32>(1.0);
    } else if best_tri == NO_HIT {
        out[p] = NO_HIT;
        out[batch.total * pixels + p] = bitcast<u32>(1.0);
    } else {
        out[p] = best_tri;
        let z = clamp((view.depth.y - view.depth.x * best_t) / best_t, 0.0, 1.0);
        out[batch.total * pixels + p] = bitcast<u32>(z);
    }
}
