//! The linear part of the sparse graph: plateaus, zones, areas, gates and portals, and the
//! vertices — labelled from the span grid, or taken from the labels a `.nav` file stores.

use super::*;

/// Disjoint sets over indices (the root of a set is its smallest member; path halving).
#[derive(Debug)]
struct Forest {
    parent: Vec<u32>,
}

impl Forest {
    fn new(n: usize) -> Self {
        Forest {
            parent: (0..n as u32).collect(),
        }
    }

    fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let up = self.parent[self.parent[x as usize] as usize];
            self.parent[x as usize] = up;
            x = up;
        }
        x
    }

    fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra < rb {
            self.parent[rb as usize] = ra;
        } else if rb < ra {
            self.parent[ra as usize] = rb;
        }
    }
}

impl<'g> Geodesic<'g> {
    /// Bits of [`Vertex::corners`] for a span: the diagonals blocked while both axis links
    /// beside them exist.
    pub(super) fn corners(&self, s: u32) -> u8 {
        let mask = self.sight.link_masks(s).1;
        let mut corners = 0u8;
        for (k, (ax, az)) in [(0, 1), (2, 1), (2, 3), (0, 3)].into_iter().enumerate() {
            // DIRS[4 + k] is the diagonal between the axis directions ax and az.
            if mask & (1 << ax) != 0 && mask & (1 << az) != 0 && mask & (16 << k) == 0 {
                corners |= 1 << k;
            }
        }
        corners
    }

    /// The linear part of the sparse graph from the grid's stored labels (checked by the
    /// caller with [`SparseLabels::fits`]): roles and zone sizes from the areas, vertex cells
    /// and corners from the grid, portal boxes from their gates' positions. `None` beyond
    /// [`SPARSE_MAX_VERTICES`] vertices.
    pub(super) fn stored_labels(&self, l: &SparseLabels) -> Option<Labels> {
        if l.verts.len() > SPARSE_MAX_VERTICES {
            return None;
        }
        let mut zone_spans: Vec<u32> = Vec::new();
        let mut role = Vec::with_capacity(l.area.len());
        for &a in &l.area {
            if a != NONE && a & IN_ZONE != 0 {
                // Below the span count (checked).
                let z = (a & !IN_ZONE) as usize;
                if z >= zone_spans.len() {
                    zone_spans.resize(z + 1, 0);
                }
                zone_spans[z] += 1;
                role.push(ZONE);
            } else {
                role.push(PLAIN);
            }
        }
        let verts: Vec<Vertex> = l
            .verts
            .iter()
            .map(|&v| {
                let s = v & !SPARSE_GATE;
                Vertex {
                    span: s,
                    xz: self.cell_xz(s),
                    pos: self.position(s).unwrap_or(Vec3::ZERO),
                    corners: self.corners(s),
                    gate: v & SPARSE_GATE != 0,
                }
            })
            .collect();
        for (i, v) in verts.iter().enumerate() {
            if let Some(r) = role.get_mut(v.span as usize) {
                *r = i as u32;
            }
        }
        let mut portals: Vec<Portal> = l
            .portals
            .iter()
            .map(|&(zone, region)| Portal {
                zone,
                region,
                lo: Vec3::INFINITY,
                hi: Vec3::NEG_INFINITY,
                near: [f32::INFINITY; LANDMARKS],
                far: [0.0; LANDMARKS],
            })
            .collect();
        for &(k, s) in &l.portal_gates {
            let p = self.position(s).unwrap_or(Vec3::ZERO);
            if let Some(q) = portals.get_mut(k as usize) {
                q.lo = q.lo.min(p);
                q.hi = q.hi.max(p);
            }
        }
        Some(Labels {
            role,
            area: l.area.clone(),
            zone_spans,
            portals,
            portal_gates: l.portal_gates.clone(),
            verts,
        })
    }

    /// The linear part of the sparse graph: plateaus, zones, areas, gates and portals, and
    /// the vertices (see [`Geodesic::build_sparse`]). `None` beyond [`SPARSE_MAX_VERTICES`]
    /// vertices.
    pub(super) fn label_spans(&self) -> Option<Labels> {
        let spans = &self.grid().spans;
        let n = spans.len();
        let sight = &self.sight;
        // Reads only the packed spans: links from masks and column offsets, heights. Spans
        // without links (the builder links walkable spans only) are on no plateau and in no
        // zone.
        let linked = |s: u32| sight.link_masks(s).1 != 0;
        let height = |s: u32| sight.column_height(s).1;
        // Plateau components by a depth-first flood over links with small steps, noting the
        // links between components (seen from the side labelled last) and the spans that
        // have such links (the only ones that can be gates).
        let mut comp = vec![NONE; n];
        let mut stats: Vec<(u32, f32, f32)> = Vec::new();
        let mut between: Vec<(u32, u32)> = Vec::new();
        let mut edge_spans: Vec<u32> = Vec::new();
        let mut stack = Vec::new();
        for seed in 0..n as u32 {
            if comp[seed as usize] != NONE || !linked(seed) {
                continue;
            }
            let id = stats.len() as u32;
            comp[seed as usize] = id;
            stack.push(seed);
            let (mut size, mut lo, mut hi) = (0u32, height(seed), height(seed));
            while let Some(s) = stack.pop() {
                let y = height(s);
                size += 1;
                lo = lo.min(y);
                hi = hi.max(y);
                let mut edge = false;
                for (l, _) in self.links_of(s) {
                    let c = comp[l as usize];
                    if (height(l) - y).abs() <= PLATEAU_STEP {
                        if c == NONE {
                            comp[l as usize] = id;
                            stack.push(l);
                        }
                    } else {
                        edge = true;
                        if c != NONE && c != id {
                            between.push((c, id));
                        }
                    }
                }
                if edge {
                    edge_spans.push(s);
                }
            }
            stats.push((size, lo, hi));
        }
        let is_zone: Vec<bool> = stats
            .iter()
            .map(|&(size, lo, hi)| !(size >= PLATEAU_MIN && hi - lo <= PLATEAU_RANGE))
            .collect();
        let zone_span = |s: u32| comp[s as usize] != NONE && is_zone[comp[s as usize] as usize];
        // Regions join linked plateaus, zones join linked zone components; numbered in the
        // order of their first span.
        let mut parts = Forest::new(stats.len());
        for &(a, b) in &between {
            if is_zone[a as usize] == is_zone[b as usize] {
                parts.union(a, b);
            }
        }
        let mut part_area = vec![NONE; stats.len()];
        let (mut regions, mut zones) = (0u32, 0u32);
        for c in 0..stats.len() as u32 {
            let r = parts.find(c) as usize;
            if part_area[r] == NONE {
                part_area[r] = if is_zone[c as usize] {
                    zones += 1;
                    IN_ZONE | (zones - 1)
                } else {
                    regions += 1;
                    regions - 1
                };
            }
            part_area[c as usize] = part_area[r];
        }
        let area: Vec<u32> = comp
            .iter()
            .map(|&c| {
                if c == NONE {
                    NONE
                } else {
                    part_area[c as usize]
                }
            })
            .collect();
        let mut zone_spans = vec![0u32; zones as usize];
        for &a in &area {
            if a != NONE && a & IN_ZONE != 0 {
                zone_spans[(a & !IN_ZONE) as usize] += 1;
            }
        }
        let mut role: Vec<u32> = (0..n as u32)
            .map(|s| if zone_span(s) { ZONE } else { PLAIN })
            .collect();
        // Gates (plateau spans linked to a zone) and the portals they form.
        let mut gates: Vec<u32> = Vec::new();
        let mut portals: Vec<Portal> = Vec::new();
        let mut portal_of = std::collections::BTreeMap::new();
        let mut portal_gates: Vec<(u32, u32)> = Vec::new();
        for &s in &edge_spans {
            if zone_span(s) {
                continue;
            }
            let mut gate = false;
            for (l, _) in self.links_of(s) {
                if !zone_span(l) {
                    continue;
                }
                gate = true;
                let (zone, region) = (area[l as usize], area[s as usize]);
                let p = self.position(s).unwrap_or(Vec3::ZERO);
                let k = *portal_of.entry((zone, region)).or_insert_with(|| {
                    portals.push(Portal {
                        zone,
                        region,
                        lo: p,
                        hi: p,
                        near: [f32::INFINITY; LANDMARKS],
                        far: [0.0; LANDMARKS],
                    });
                    portals.len() - 1
                });
                portals[k].lo = portals[k].lo.min(p);
                portals[k].hi = portals[k].hi.max(p);
                portal_gates.push((k as u32, s));
            }
            if gate {
                gates.push(s);
            }
        }
        gates.sort_unstable();
        // Vertices: corners (from the link masks) and gates, in span order.
        let mut corner_spans: Vec<(u32, u8, bool)> = Vec::new();
        let mut next_gate = gates.iter().peekable();
        for s in 0..n as u32 {
            let corners = self.corners(s);
            let gate = next_gate.next_if(|&&g| g == s).is_some();
            if gate || corners != 0 {
                corner_spans.push((s, corners, gate));
            }
        }
        if corner_spans.len() > SPARSE_MAX_VERTICES {
            return None;
        }
        corner_spans.sort_unstable_by_key(|v| v.0);
        let verts: Vec<Vertex> = corner_spans
            .iter()
            .map(|&(s, corners, gate)| Vertex {
                span: s,
                xz: self.cell_xz(s),
                pos: self.position(s).unwrap_or(Vec3::ZERO),
                corners,
                gate,
            })
            .collect();
        for (i, v) in verts.iter().enumerate() {
            role[v.span as usize] = i as u32;
        }
        Some(Labels {
            role,
            area,
            zone_spans,
            portals,
            portal_gates,
            verts,
        })
    }
}
