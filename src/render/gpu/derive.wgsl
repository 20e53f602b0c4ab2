// minos's GPU image derivation: the second compute pass of a ray-traced batch. One invocation
// per pixel reads the triangle id and depth-buffer value the trace pass wrote and derives the
// images a batch asked for with the formulas of `render/frame.rs` (colour: material colour
// times the bilinear, repeat-wrapped texture at the pixel ray's exact coordinates, one
// directional light plus ambient; linear depth; normals; labels), so the host reads back
// finished images.

struct Tri {
    // xyz: unit normal; w: texture index (NO_TEXTURE: none).
    a: vec4<u32>,
    // xyz: colour (0-1); w: object index + 1.
    b: vec4<u32>,
    // xyz: the texture map's origin; w: room index + 1.
    c: vec4<u32>,
    // xy: texture coordinates at the origin; z: nyu40 | mpcat40 << 16; w: coarse | room class << 16.
    d: vec4<u32>,
    // xyz: gradient of u.
    du: vec4<u32>,
    // xyz: gradient of v.
    dv: vec4<u32>,
};

struct View {
    origin: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    forward: vec4<f32>,
    // near, far, tan(vfov / 2), aspect.
    lens: vec4<f32>,
    depth: vec4<f32>,
    slot: vec4<u32>,
};

struct Derive {
    first: u32,
    total: u32,
    width: u32,
    height: u32,
    // xyz: unit direction towards the light; w: the ambient share.
    light: vec4<f32>,
    // Where each channel's words start in `out` (EMPTY: not asked for), in `Channel::ALL`
    // order: colour, depth, normal, nyu40, mpcat40, coarse, instance, room, room class.
    at: array<vec4<u32>, 3>,
};

const EMPTY: u32 = 0xffffffffu;
const NO_HIT: u32 = 0xffffffffu;
const OVERFLOW: u32 = 0xfffffffeu;
const NO_TEXTURE: u32 = 0xffffffffu;

@group(0) @binding(0) var<storage, read> tris: array<Tri>;
// Word 0: the number of textures n; words 4..4 + 4·n: per texture (first texel, width, height,
// 0); then texels as r | g << 8 | b << 16.
@group(0) @binding(1) var<storage, read> texels: array<u32>;
@group(1) @binding(0) var<storage, read> views: array<View>;
@group(1) @binding(1) var<storage, read_write> out: array<u32>;
@group(1) @binding(2) var<uniform> batch: Derive;

fn f3(v: vec4<u32>) -> vec3<f32> {
    return vec3<f32>(bitcast<f32>(v.x), bitcast<f32>(v.y), bitcast<f32>(v.z));
}

fn channel(k: u32) -> u32 {
    return batch.at[k / 4u][k % 4u];
}

// `t` wrapped into [0, 1] (|t| ≤ 1e6), as `texture::wrap01`.
fn wrap01(t: f32) -> f32 {
    let f = t - f32(i32(t));
    return select(f, f + 1.0, f < 0.0);
}

// ⌊x⌋ for x ≥ −1, as `texture::floor_small`.
fn floor_small(x: f32) -> i32 {
    return select(i32(x), -1, x < 0.0);
}

fn wrap_index(i: i32, n: u32) -> u32 {
    if i < 0 {
        return n - 1u;
    }
    if u32(i) >= n {
        return 0u;
    }
    return u32(i);
}

fn texel(first: u32, w: u32, x: u32, y: u32) -> vec3<f32> {
    let p = texels[first + y * w + x];
    return vec3<f32>(f32(p & 255u), f32((p >> 8u) & 255u), f32((p >> 16u) & 255u)) / 255.0;
}

// Bilinear sample with repeat wrap, as `Texture::sample`.
fn sample(tex: u32, u: f32, v: f32) -> vec3<f32> {
    let first = texels[4u + 4u * tex];
    let w = texels[5u + 4u * tex];
    let h = texels[6u + 4u * tex];
    if !(abs(u) <= 1e6) || !(abs(v) <= 1e6) {
        return texel(first, w, 0u, 0u);
    }
    let x = wrap01(u) * f32(w) - 0.5;
    let y = wrap01(1.0 - v) * f32(h) - 0.5;
    let xi = floor_small(x);
    let yi = floor_small(y);
    let fx = x - f32(xi);
    let fy = y - f32(yi);
    let xa = wrap_index(xi, w);
    let xb = wrap_index(xi + 1, w);
    let ya = wrap_index(yi, h);
    let yb = wrap_index(yi + 1, h);
    let a = texel(first, w, xa, ya);
    let b = texel(first, w, xb, ya);
    let c = texel(first, w, xa, yb);
    let d = texel(first, w, xb, yb);
    let top = a + (b - a) * fx;
    let bottom = c + (d - c) * fx;
    return top + (bottom - top) * fy;
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let w = batch.width;
    let h = batch.height;
    if gid.x >= w || gid.y >= h {
        return;
    }
    let view = views[batch.first + gid.z];
    let pixels = w * h;
    let p = view.slot.x * pixels + gid.y * w + gid.x;
    let id = out[p];
    // A ray whose stack overflowed is cast again on the host, which derives that view itself.
    if id == OVERFLOW {
        return;
    }
    let hit = id != NO_HIT;
    let z = bitcast<f32>(out[batch.total * pixels + p]);
    var tri: Tri;
    if hit {
        tri = tris[id];
    }
    let normal = f3(tri.a);

    let at_color = channel(0u);
    if at_color != EMPTY {
        var rgb = vec3<u32>(0u);
        if hit {
            let light = batch.light.xyz;
            let ambient = batch.light.w;
            let shade = ambient + (1.0 - ambient) * abs(dot(normal, light));
            var c = f3(tri.b);
            let tex = tri.a.w;
            if tex != NO_TEXTURE && tex < texels[0] {
                // The pixel centre's ray, as the trace pass (and `PixelRays`) makes it.
                let tan = view.lens.z;
                let aspect = view.lens.w;
                let sx = ((f32(gid.x) + 0.5) / f32(w) * 2.0 - 1.0) * tan * aspect;
                let sy = (1.0 - (f32(gid.y) + 0.5) / f32(h) * 2.0) * tan;
                let dir = view.right.xyz * sx + (view.forward.xyz + view.up.xyz * sy);
                // `UvMap::at`: where the ray meets the triangle's plane.
                let wv = view.origin.xyz - f3(tri.c);
                let nd = dot(normal, dir);
                var q = vec3<f32>(0.0);
                if abs(nd) > 1e-12 {
                    q = wv - dir * (dot(normal, wv) / nd);
                }
                let u = bitcast<f32>(tri.d.x) + dot(f3(tri.du), q);
                let v = bitcast<f32>(tri.d.y) + dot(f3(tri.dv), q);
                c = c * sample(tex, u, v);
            }
            rgb = vec3<u32>(clamp(c * shade, vec3<f32>(0.0), vec3<f32>(1.0)) * 255.0 + 0.5);
        }
        out[at_color + p] = rgb.x | (rgb.y << 8u) | (rgb.z << 16u);
    }
    let at_depth = channel(1u);
    if at_depth != EMPTY {
        var d = 0.0;
        if hit {
            let near = view.lens.x;
            let far = view.lens.y;
            d = near * far / (far - z * (far - near));
        }
        out[at_depth + p] = bitcast<u32>(d);
    }
    let at_normal = channel(2u);
    if at_normal != EMPTY {
        var n = vec3<u32>(0u);
        if hit {
            n = tri.a.xyz;
        }
        out[at_normal + 3u * p] = n.x;
        out[at_normal + 3u * p + 1u] = n.y;
        out[at_normal + 3u * p + 2u] = n.z;
    }
    // Labels: 0 where nothing is hit (the zeroed record).
    var labels = array<u32, 6>(
        tri.d.z & 0xffffu,
        tri.d.z >> 16u,
        tri.d.w & 0xffffu,
        tri.b.w,
        tri.c.w,
        tri.d.w >> 16u,
    );
    for (var k = 0u; k < 6u; k++) {
        let at = channel(3u + k);
        if at != EMPTY {
            out[at + p] = labels[k];
        }
    }
}
