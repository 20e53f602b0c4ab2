//! [`NavGrid::validate`]: the invariants every query indexes by, checked on a grid read from a
//! file, so a corrupt grid is a one-line error instead of an index out of bounds later.

use crate::invalid::Invalid;

use super::grid::{NavGrid, DIRS, NONE};

impl NavGrid {
    /// Checks that the grid can be queried without indexing out of range: parameters usable,
    /// origin finite, one column start per column plus one, in order and ending at the span
    /// count; every span's numbers not NaN, its links `NONE` or a span of the neighbouring
    /// column in that direction, its room and island `NONE` or in range; every span-object
    /// pair in range; room classes 0–8. Returns the first problem, naming the record
    /// (`span 12: link 3 to span 99 …`).
    pub fn validate(&self) -> Result<(), Invalid> {
        self.params
            .validate()
            .map_err(Invalid::inside("parameters"))?;
        if !self.x0.is_finite() || !self.z0.is_finite() {
            return Err(format!("origin ({}, {}) not finite", self.x0, self.z0).into());
        }
        let columns = u64::from(self.nx) * u64::from(self.nz);
        if self.column_start.len() as u64 != columns + 1 {
            return Err(format!(
                "{} column starts for {} x {} columns",
                self.column_start.len(),
                self.nx,
                self.nz
            )
            .into());
        }
        let n = self.spans.len();
        if self.column_start.first() != Some(&0)
            || self.column_start.last().map(|&c| c as usize) != Some(n)
            || self.column_start.windows(2).any(|w| w[0] > w[1])
        {
            return Err("column starts do not cover the spans in order".into());
        }
        let (nx, nz) = (i64::from(self.nx), i64::from(self.nz));
        let (nrooms, nislands) = (self.rooms.len(), self.islands.len());
        for c in 0..columns as usize {
            let (ix, iz) = ((c as i64) % nx, (c as i64) / nx);
            for s in self.column_spans(c) {
                let span = &self.spans[s];
                if span.y.is_nan() || span.headroom.is_nan() || span.clearance.is_nan() {
                    return Err(format!("span {s}: NaN height, headroom or clearance").into());
                }
                if span.room != NONE && span.room as usize >= nrooms {
                    return Err(format!(
                        "span {s}: room {} out of range for {nrooms} rooms",
                        span.room
                    )
                    .into());
                }
                if span.island != NONE && span.island as usize >= nislands {
                    return Err(format!(
                        "span {s}: island {} out of range for {nislands} islands",
                        span.island
                    )
                    .into());
                }
                for (d, &l) in span.links.iter().enumerate() {
                    if l == NONE {
                        continue;
                    }
                    let (jx, jz) = (ix + i64::from(DIRS[d].0), iz + i64::from(DIRS[d].1));
                    let inside = (0..nx).contains(&jx) && (0..nz).contains(&jz);
                    let target = (jz * nx + jx) as usize;
                    if !inside || !self.column_spans(target).contains(&(l as usize)) {
                        return Err(format!(
                            "span {s}: link {d} to span {l}, not a span of the neighbouring column"
                        )
                        .into());
                    }
                }
            }
        }
        let nobjects = self.objects.len();
        if let Some((s, o)) = self
            .span_objects
            .iter()
            .find(|&&(s, o)| s as usize >= n || o as usize >= nobjects)
        {
            return Err(format!(
                "span object ({s}, {o}) out of range for {n} spans and {nobjects} objects"
            )
            .into());
        }
        if let Some(r) = self.rooms.iter().find(|r| r.class > 8) {
            return Err(format!("room {}: class {} is not 0-8", r.id, r.class).into());
        }
        Ok(())
    }
}
