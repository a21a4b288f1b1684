//! The mirror-symmetric full table (docs/design.md §4.6): on the full grid (θi, φi, θo, φo), a
//! model whose f is unchanged when both directions are mirrored across the xz plane (y → −y,
//! φ → −φ) or the yz plane (x → −x, φ → π − φ) has f(θi, σ(φi), θo, σ(φo)) = f(θi, φi, θo, φo)
//! for σ each of φ → −φ, φ → π − φ and their product φ → π + φ. With cell-centred φ axes
//! (§4.1) these map cell k of an axis of N cells to N − 1 − k, (N/2 − 1 − k) mod N and
//! (N/2 + k) mod N, so with NPHI_I a multiple of 4 and NPHI_O even only the light directions
//! with φi in the first quadrant (φi index < NPHI_I/4) are evaluated, a quarter of the table,
//! and every other cell is a copy of one of them.
//!
//! The evaluated cells are the outer product of those light directions (row r = ti · NPHI_I/4 +
//! a) and every view direction (view cell v = to · NPHI_O + b), r after r.
//! [`Quadrants::scatter`] hands a chunk of them on as runs of the table: each row segment in
//! place, and its three images, the image of light cell a under σ holding in view cell (to, b)
//! the evaluated value at (to, σ(b)) (each σ is its own inverse). Whole view blocks (one θo)
//! of an image are contiguous in the destination row; the at most two partial blocks where a
//! chunk starts or ends inside a block go out in pieces. A chunk needs at most its own size
//! again in scratch memory.

use super::TableSink;
use anyhow::Result;

/// The quarter of a full table that is evaluated, and where its images go.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quadrants {
    n_theta_i: u64,
    n_phi_i: u64,
    n_theta_o: u64,
    n_phi_o: u64,
}

/// A reflection of the φ axis as it acts on cell indices of an axis of `n` cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Reflection {
    /// φ → −φ (y → −y): k → n − 1 − k.
    Y,
    /// φ → π − φ (x → −x): k → (n/2 − 1 − k) mod n.
    X,
    /// φ → π + φ (both): k → (n/2 + k) mod n.
    Both,
}

impl Reflection {
    const ALL: [Reflection; 3] = [Reflection::Y, Reflection::X, Reflection::Both];

    /// The image of cell `k` of an axis of `n` cells (n even).
    fn cell(self, k: u64, n: u64) -> u64 {
        match self {
            Reflection::Y => n - 1 - k,
            Reflection::X => (n / 2 + n - 1 - k) % n,
            Reflection::Both => (n / 2 + k) % n,
        }
    }
}

impl Reflection {
    /// Appends to `out` the image of one whole view block (`block`: the 3 f32 of each of an
    /// even number of φ cells), cell b of the image holding cell [`Reflection::cell`] of b: the
    /// block reversed, each half reversed, or the halves swapped.
    fn push_block(self, block: &[f32], out: &mut Vec<f32>) {
        let half = block.len() / 2;
        let reversed = |part: &[f32], out: &mut Vec<f32>| {
            part.rchunks_exact(3).for_each(|c| out.extend_from_slice(c))
        };
        match self {
            Reflection::Y => reversed(block, out),
            Reflection::X => {
                reversed(&block[..half], out);
                reversed(&block[half..], out);
            }
            Reflection::Both => {
                out.extend_from_slice(&block[half..]);
                out.extend_from_slice(&block[..half]);
            }
        }
    }
}

impl Quadrants {
    /// The quarter of an `n_theta_i` × `n_phi_i` × `n_theta_o` × `n_phi_o` full table, where
    /// the φ axes allow it: NPHI_I a multiple of 4 (the first quadrant holds whole cells) and
    /// NPHI_O even.
    pub fn new(n_theta_i: u64, n_phi_i: u64, n_theta_o: u64, n_phi_o: u64) -> Option<Quadrants> {
        (n_phi_i.is_multiple_of(4) && n_phi_o.is_multiple_of(2) && n_phi_i > 0 && n_phi_o > 0)
            .then_some(Quadrants {
                n_theta_i,
                n_phi_i,
                n_theta_o,
                n_phi_o,
            })
    }

    /// Light cells per θi evaluated: NPHI_I/4.
    fn quarter(&self) -> u64 {
        self.n_phi_i / 4
    }

    /// Cells of one light direction's row: NTHETA_O · NPHI_O.
    fn row(&self) -> u64 {
        self.n_theta_o * self.n_phi_o
    }

    /// Cells evaluated: a quarter of the table.
    pub fn cells(&self) -> u64 {
        self.n_theta_i * self.quarter() * self.row()
    }

    /// The light directions evaluated, as indices into the full grid's light list
    /// (ti · NPHI_I + a, a < NPHI_I/4), in the order of their rows.
    pub fn light_cells(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.n_theta_i)
            .flat_map(move |ti| (0..self.quarter()).map(move |a| (ti * self.n_phi_i + a) as usize))
    }

    /// Hands evaluated cells `first ..` (`values`: 3 f32 per cell) to `sink` as runs of the
    /// table: the cells themselves, then their images, each cell of the table once over all
    /// chunks. `scratch` holds one image at a time (its memory is reused).
    pub fn scatter(
        &self,
        first: u64,
        values: &[f32],
        scratch: &mut Vec<f32>,
        sink: &mut TableSink<'_>,
    ) -> Result<()> {
        let row = self.row();
        let count = values.len() as u64 / 3;
        let (mut r, mut v) = (first / row, first % row);
        let mut offset = 0;
        while offset < count {
            let take = (row - v).min(count - offset);
            let segment = &values[(offset * 3) as usize..((offset + take) * 3) as usize];
            let (ti, a) = (r / self.quarter(), r % self.quarter());
            let light_row = |a: u64| (ti * self.n_phi_i + a) * row;
            sink(light_row(a) + v, segment)?;
            for sigma in Reflection::ALL {
                let dest = light_row(sigma.cell(a, self.n_phi_i));
                self.image(sigma, dest, v, segment, scratch, sink)?;
            }
            offset += take;
            r += 1;
            v = 0;
        }
        Ok(())
    }

    /// The image under `sigma` of the evaluated view cells `v ..` (`segment`) of one row, into
    /// the destination row starting at table cell `dest`.
    fn image(
        &self,
        sigma: Reflection,
        dest: u64,
        v: u64,
        segment: &[f32],
        scratch: &mut Vec<f32>,
        sink: &mut TableSink<'_>,
    ) -> Result<()> {
        let np = self.n_phi_o;
        let cells = segment.len() as u64 / 3;
        let value = |k: u64| &segment[(k * 3) as usize..(k * 3 + 3) as usize];
        // Consecutive whole view blocks, gathered into scratch: (first destination cell).
        let mut whole: Option<u64> = None;
        scratch.clear();
        let mut k = 0;
        while k < cells {
            let (o, b0) = ((v + k) / np, (v + k) % np);
            let b1 = np.min(b0 + cells - k);
            if b0 == 0 && b1 == np {
                whole.get_or_insert(dest + o * np);
                let block = &segment[(k * 3) as usize..((k + np) * 3) as usize];
                sigma.push_block(block, scratch);
            } else {
                if let Some(at) = whole.take() {
                    sink(at, scratch)?;
                    scratch.clear();
                }
                // A partial block: each cell to its image, in runs of consecutive cells.
                let mut pieces: Vec<(u64, u64)> =
                    (b0..b1).map(|b| (sigma.cell(b, np), k + b - b0)).collect();
                pieces.sort_unstable();
                let mut start = 0;
                for end in 1..=pieces.len() {
                    if end == pieces.len() || pieces[end].0 != pieces[end - 1].0 + 1 {
                        let run: Vec<f32> = pieces[start..end]
                            .iter()
                            .flat_map(|&(_, src)| value(src).iter().copied())
                            .collect();
                        sink(dest + o * np + pieces[start].0, &run)?;
                        start = end;
                    }
                }
            }
            k += b1 - b0;
        }
        if let Some(at) = whole {
            sink(at, scratch)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::scatter_tests::scattered;

    /// A value that names its cell (ti, a, to, b), exact in f32 for the sizes used here.
    fn tag(ti: u64, a: u64, to: u64, b: u64) -> [f32; 3] {
        [(ti * 1000 + a) as f32, to as f32, b as f32]
    }

    #[test]
    fn reflections_are_their_own_inverses_and_the_geometric_ones() {
        use std::f64::consts::PI;
        for n in [2u64, 4, 6, 8, 12] {
            let phi = |k: u64| (k as f64 + 0.5) * 2.0 * PI / n as f64;
            for k in 0..n {
                for (sigma, image) in [
                    (Reflection::Y, -phi(k)),
                    (Reflection::X, PI - phi(k)),
                    (Reflection::Both, PI + phi(k)),
                ] {
                    let j = sigma.cell(k, n);
                    assert_eq!(sigma.cell(j, n), k, "{sigma:?} n {n} k {k}");
                    let d = (phi(j) - image).rem_euclid(2.0 * PI);
                    assert!(d.min(2.0 * PI - d) < 1e-9, "{sigma:?} n {n} k {k} -> {j}");
                }
            }
        }
    }

    /// Every table cell arrives exactly once and holds the value of the evaluated cell it is an
    /// image of, whatever the chunk size (chunks that start and end inside a view block too).
    #[test]
    fn scatter_fills_every_cell_once_with_its_image() {
        for (nti, npi, nto, npo) in [(1, 4, 1, 2), (2, 8, 3, 4), (3, 4, 2, 6), (1, 12, 2, 10)] {
            let q = Quadrants::new(nti, npi, nto, npo).unwrap();
            let row = nto * npo;
            let lights: Vec<usize> = q.light_cells().collect();
            let evaluated: Vec<f32> = lights
                .iter()
                .flat_map(|&l| {
                    let (ti, a) = (l as u64 / npi, l as u64 % npi);
                    (0..row).flat_map(move |v| tag(ti, a, v / npo, v % npo))
                })
                .collect();
            assert_eq!(evaluated.len() as u64, q.cells() * 3);
            let cells = (nti * npi * row) as usize;
            for chunk in [1, 2, 5, 7, npo as usize + 1, q.cells() as usize] {
                let (table, seen) = scattered(
                    cells,
                    &evaluated,
                    chunk,
                    &mut |first, values, scratch, sink| q.scatter(first, values, scratch, sink),
                );
                assert!(
                    seen.iter().all(|&s| s == 1),
                    "{nti},{npi},{nto},{npo} chunk {chunk}"
                );
                for ti in 0..nti {
                    for a in 0..npi {
                        for to in 0..nto {
                            for b in 0..npo {
                                // The evaluated cell of this orbit: the reflection that takes
                                // a into the first quadrant, applied to b as well.
                                let (a0, b0) = if a < npi / 4 {
                                    (a, b)
                                } else {
                                    let s = Reflection::ALL
                                        .into_iter()
                                        .find(|s| s.cell(a, npi) < npi / 4)
                                        .unwrap();
                                    (s.cell(a, npi), s.cell(b, npo))
                                };
                                let cell = (((ti * npi + a) * nto + to) * npo + b) as usize;
                                assert_eq!(
                                    table[cell * 3..cell * 3 + 3],
                                    tag(ti, a0, to, b0),
                                    "({ti}, {a}, {to}, {b}) chunk {chunk}"
                                );
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn only_axes_that_hold_whole_quadrants_qualify() {
        assert!(Quadrants::new(2, 6, 2, 4).is_none());
        assert!(Quadrants::new(2, 8, 2, 5).is_none());
        assert!(Quadrants::new(2, 8, 2, 4).is_some());
        assert_eq!(Quadrants::new(3, 8, 5, 6).unwrap().cells(), 3 * 2 * 30);
    }
}
