//! Landmark distances of the sparse graph (the A* bound the search starts from).

use super::*;

/// Graph distances from every vertex of a graph (edges of vertex `i` in
/// `edges[first[i]..first[i + 1]]`) to [`LANDMARKS`] landmarks in its largest connected
/// part, chosen farthest first: the first is the vertex farthest from the part's first
/// vertex, each next one the vertex farthest from those before.
pub(super) fn landmarks(first: &[u32], edges: &[(u32, f32)]) -> Vec<[f32; LANDMARKS]> {
    let n = first.len().saturating_sub(1);
    let mut marks = vec![[f32::INFINITY; LANDMARKS]; n];
    if n == 0 {
        return marks;
    }
    let dijkstra = |from: usize, out: &mut Vec<f32>| {
        out.clear();
        out.resize(n, f32::INFINITY);
        out[from] = 0.0;
        let mut heap = BinaryHeap::new();
        heap.push(Reverse((0u32, from as u32)));
        while let Some(Reverse((d, v))) = heap.pop() {
            let d = f32::from_bits(d);
            if d > out[v as usize] {
                continue;
            }
            let (a, b) = (first[v as usize] as usize, first[v as usize + 1] as usize);
            for &(w, len) in &edges[a..b] {
                let c = d + len;
                if c < out[w as usize] {
                    out[w as usize] = c;
                    heap.push(Reverse((c.to_bits(), w)));
                }
            }
        }
    };
    // The largest connected part.
    let mut part = vec![u32::MAX; n];
    let (mut seed, mut best, mut stack) = (0, 0, Vec::new());
    for v in 0..n {
        if part[v] != u32::MAX {
            continue;
        }
        part[v] = v as u32;
        stack.push(v);
        let mut size = 0;
        while let Some(u) = stack.pop() {
            size += 1;
            let (a, b) = (first[u] as usize, first[u + 1] as usize);
            for &(w, _) in &edges[a..b] {
                if part[w as usize] == u32::MAX {
                    part[w as usize] = v as u32;
                    stack.push(w as usize);
                }
            }
        }
        if size > best {
            (seed, best) = (v, size);
        }
    }
    let mut dist = Vec::new();
    dijkstra(seed, &mut dist);
    // Distance of each vertex of the part to the nearest landmark so far (-1 outside).
    let mut near: Vec<f32> = dist
        .iter()
        .map(|&d| if d.is_finite() { d } else { -1.0 })
        .collect();
    for k in 0..LANDMARKS {
        let pick = (0..n)
            .max_by(|&a, &b| near[a].total_cmp(&near[b]).then(b.cmp(&a)))
            .unwrap_or(0);
        dijkstra(pick, &mut dist);
        for ((mark, near), &d) in marks.iter_mut().zip(&mut near).zip(&dist) {
            mark[k] = d;
            if *near >= 0.0 {
                *near = if k == 0 { d } else { near.min(d) };
            }
        }
    }
    marks
}
