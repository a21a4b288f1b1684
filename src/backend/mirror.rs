//! The reciprocal isotropic table (docs/design.md §4.5): on the isotropic grid with equal θ axes,
//! reciprocity and isotropy give f(θi, θo, Δφ) = f(θo, θi, Δφ), so only the cells with
//! θo index ≥ θi index (the upper triangle, diagonal included) are evaluated and every other cell
//! is a copy of its mirror image. The evaluated cells are packed row after row: row i holds
//! (i, o, d) for o = i .. n − 1 and every d, that is the view cells i · NDPHI .. n · NDPHI − 1.
//!
//! [`UpperTriangle::scatter`] turns one chunk of packed cells into runs of the table: each row
//! segment is a run, and so is each Δφ run of the chunk's cells (i, o, ·), o > i, read again as
//! its mirror image (o, i, ·). The runs are slices of the chunk itself: the mirror images take no
//! memory and no copy of their own.

use super::TableSink;
use anyhow::Result;

/// The packed upper triangle of an isotropic table of `n` θ cells on each θ axis and `n_dphi`
/// Δφ cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UpperTriangle {
    n: u64,
    n_dphi: u64,
}

/// (θi, θo) pairs in the last `r` rows of a triangle: r(r + 1)/2.
fn tail_pairs(r: u64) -> u64 {
    r * (r + 1) / 2
}

impl UpperTriangle {
    /// The triangle of an `n` × `n` × `n_dphi` table.
    pub fn new(n: u64, n_dphi: u64) -> UpperTriangle {
        UpperTriangle { n, n_dphi }
    }

    /// Cells of the whole table.
    pub fn table_cells(&self) -> u64 {
        self.n * self.n * self.n_dphi
    }

    /// Cells evaluated: n(n + 1)/2 · NDPHI.
    pub fn cells(&self) -> u64 {
        tail_pairs(self.n) * self.n_dphi
    }

    /// Row i and view cell (o · NDPHI + d) of packed cell `cell` (< [`UpperTriangle::cells`]).
    /// Twin of `upper_start` in glsl/kernels/table.comp, in exact integer arithmetic: counted
    /// from the end, the q-th pair lies in row n − 1 − r with r(r + 1)/2 ≤ q < (r + 1)(r + 2)/2.
    pub fn locate(&self, cell: u64) -> (u64, u64) {
        let pair = cell / self.n_dphi;
        let d = cell % self.n_dphi;
        let q = tail_pairs(self.n) - 1 - pair;
        let mut r = (((8 * q + 1) as f64).sqrt() as u64).saturating_sub(1) / 2;
        while r > 0 && tail_pairs(r) > q {
            r -= 1;
        }
        while tail_pairs(r + 1) <= q {
            r += 1;
        }
        let i = self.n - 1 - r;
        let o = self.n - 1 - (q - tail_pairs(r));
        (i, o * self.n_dphi + d)
    }

    /// Hands packed cells `first ..` (`values`: 3 f32 per cell) to `sink` as runs of the table
    /// (first table cell, values): the cells themselves, then their mirror images, each cell of
    /// the table once over all chunks. Every run is a slice of `values`: a mirror image (o, i, ·)
    /// is the chunk's Δφ run of (i, o, ·), so nothing is copied here. A destination row o gets
    /// its runs in order of i, one after the other in the table.
    pub fn scatter(&self, first: u64, values: &[f32], sink: &mut TableSink<'_>) -> Result<()> {
        let (n, nd) = (self.n, self.n_dphi);
        let n_wo = n * nd;
        let count = values.len() as u64 / 3;
        if count == 0 {
            return Ok(());
        }
        let cells = |from: u64, len: u64| &values[(from * 3) as usize..((from + len) * 3) as usize];
        // The chunk's row segments: (row, first view cell, end view cell, offset in the chunk).
        let mut segments = Vec::new();
        let (mut i, mut v) = self.locate(first);
        let mut offset = 0u64;
        while offset < count {
            let take = (n_wo - v).min(count - offset);
            sink(i * n_wo + v, cells(offset, take))?;
            segments.push((i, v, v + take, offset));
            offset += take;
            i += 1;
            v = i * nd;
        }
        // Mirror images: (o, i, d) for the chunk's rows i < o, destination row by row.
        for o in segments[0].0 + 1..n {
            for &(i, va, vb, offset) in segments.iter().take_while(|s| s.0 < o) {
                let (lo, hi) = ((o * nd).max(va), ((o + 1) * nd).min(vb));
                if lo < hi {
                    sink(
                        o * n_wo + i * nd + (lo - o * nd),
                        cells(offset + lo - va, hi - lo),
                    )?;
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::scatter_tests::scattered;

    /// A value that names its cell (i, o, d) of an n × n × nd table, exact in f32 for the sizes
    /// used here.
    fn tag(i: u64, o: u64, d: u64) -> [f32; 3] {
        [i as f32, o as f32, d as f32]
    }

    #[test]
    fn locate_walks_the_packed_cells_in_order() {
        for (n, nd) in [(1, 1), (1, 5), (2, 3), (7, 1), (9, 4), (64, 3)] {
            let t = UpperTriangle::new(n, nd);
            let mut k = 0;
            for i in 0..n {
                for v in i * nd..n * nd {
                    assert_eq!(t.locate(k), (i, v), "n {n}, nd {nd}, packed cell {k}");
                    k += 1;
                }
            }
            assert_eq!(k, t.cells());
        }
    }

    #[test]
    fn locate_is_exact_near_the_32_bit_limit() {
        // 65535² cells: the largest square θ grid of the kernel's 32-bit cell index.
        let t = UpperTriangle::new(65535, 1);
        assert_eq!(t.locate(0), (0, 0));
        assert_eq!(t.locate(65534), (0, 65534));
        assert_eq!(t.locate(65535), (1, 1));
        assert_eq!(t.locate(t.cells() - 1), (65534, 65534));
        assert_eq!(t.locate(t.cells() - 2), (65533, 65534));
        assert_eq!(t.locate(t.cells() - 3), (65533, 65533));
    }

    /// Every table cell arrives exactly once and holds its canonical cell's value, whatever the
    /// chunk size (chunks that start and end inside a row and inside a Δφ run included).
    #[test]
    fn scatter_fills_every_cell_once_with_its_mirror() {
        for (n, nd) in [(1, 1), (3, 1), (5, 4), (8, 3)] {
            let t = UpperTriangle::new(n, nd);
            let packed: Vec<f32> = (0..t.cells())
                .flat_map(|k| {
                    let (i, v) = t.locate(k);
                    tag(i, v / nd, v % nd)
                })
                .collect();
            for chunk in [1, 2, 3, 7, 13, t.cells() as usize] {
                let (table, seen) = scattered(
                    t.table_cells() as usize,
                    &packed,
                    chunk,
                    &mut |first, values, _, sink| t.scatter(first, values, sink),
                );
                assert!(seen.iter().all(|&s| s == 1), "n {n} nd {nd} chunk {chunk}");
                for a in 0..n {
                    for b in 0..n {
                        for d in 0..nd {
                            let cell = ((a * n + b) * nd + d) as usize;
                            let want = tag(a.min(b), a.max(b), d);
                            assert_eq!(table[cell * 3..cell * 3 + 3], want, "({a}, {b}, {d})");
                        }
                    }
                }
            }
        }
    }
}
