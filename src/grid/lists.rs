//! The light and view direction lists of the product grids (`full`, `isotropic`): cell
//! i·len(wo) + o is the pair (wi[i], wo[o]).

use super::angles::{direction, direction_product, dphi_cell, phi_cell, theta_cell};
use super::Grid;
use glam::DVec3;
use std::sync::{Arc, Mutex};

impl Grid {
    /// [`Grid::wi_list`] and [`Grid::wo_list`], shared: the lists of the last grid asked for
    /// are kept (one grid's, process-wide), so that repeated tables of one grid (a benchmark's
    /// runs, a scene's tables) make them once; they took 0.16 ms of a 12 ms table.
    pub fn lists(&self) -> Arc<(Vec<DVec3>, Vec<DVec3>)> {
        static LAST: Mutex<Option<(Grid, Arc<(Vec<DVec3>, Vec<DVec3>)>)>> = Mutex::new(None);
        let mut last = LAST.lock().unwrap_or_else(|e| e.into_inner());
        match &*last {
            Some((grid, lists)) if grid == self => lists.clone(),
            _ => {
                let lists = Arc::new((self.wi_list(), self.wo_list()));
                *last = Some((*self, lists.clone()));
                lists
            }
        }
    }

    /// Light directions in row-major order of their axes.
    pub fn wi_list(&self) -> Vec<DVec3> {
        match *self {
            Grid::Full {
                n_theta_i, n_phi_i, ..
            } => direction_product(
                (0..n_theta_i).map(|t| theta_cell(t, n_theta_i)),
                &(0..n_phi_i)
                    .map(|p| phi_cell(p, n_phi_i))
                    .collect::<Vec<_>>(),
            ),
            Grid::Isotropic { n_theta_i, .. } => (0..n_theta_i)
                .map(|t| direction(theta_cell(t, n_theta_i), 0.0))
                .collect(),
            // Not a product: see `pair`.
            Grid::HalfDiff { .. } | Grid::HalfDiffFull { .. } => Vec::new(),
        }
    }

    /// View directions in row-major order of their axes.
    pub fn wo_list(&self) -> Vec<DVec3> {
        match *self {
            Grid::Full {
                n_theta_o, n_phi_o, ..
            } => direction_product(
                (0..n_theta_o).map(|t| theta_cell(t, n_theta_o)),
                &(0..n_phi_o)
                    .map(|p| phi_cell(p, n_phi_o))
                    .collect::<Vec<_>>(),
            ),
            Grid::Isotropic {
                n_theta_o, n_dphi, ..
            } => direction_product(
                (0..n_theta_o).map(|t| theta_cell(t, n_theta_o)),
                &(0..n_dphi)
                    .map(|d| dphi_cell(d, n_dphi))
                    .collect::<Vec<_>>(),
            ),
            Grid::HalfDiff { .. } | Grid::HalfDiffFull { .. } => Vec::new(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shared lists are the grid's own, also when another grid's were asked for in between
    /// (other tests may ask for theirs at the same time).
    #[test]
    fn shared_lists_follow_the_grid() {
        let a = Grid::parse("isotropic", "3,4,5").unwrap();
        let b = Grid::parse("full", "2,3,4,5").unwrap();
        for g in [a, a, b, a, b, b] {
            let lists = g.lists();
            assert_eq!(lists.0, g.wi_list());
            assert_eq!(lists.1, g.wo_list());
        }
    }

    /// The lists hold each cell's pair ([`Grid::pair_at`], [`direction`] of its angles) to the
    /// bit: cell k has light direction k / NWO and view direction k % NWO.
    #[test]
    fn direction_lists_are_each_cells_directions() {
        let grids = [
            Grid::parse("full", "5,12,7,9"),
            Grid::parse("isotropic", "6,11,13"),
        ];
        let bits = |v: DVec3| v.to_array().map(f64::to_bits);
        for grid in grids.map(Result::unwrap) {
            let (wi, wo) = (grid.wi_list(), grid.wo_list());
            for cell in 0..grid.cells().unwrap() {
                let (k, n) = (cell as usize, wo.len());
                let (a, b) = grid.pair_at(cell);
                assert_eq!(bits(wi[k / n]), bits(a), "{grid:?} cell {cell}");
                assert_eq!(bits(wo[k % n]), bits(b), "{grid:?} cell {cell}");
            }
        }
    }

    #[test]
    fn lists_multiply_to_the_shape() {
        let g = Grid::parse("full", "3,4,5,6").unwrap();
        assert_eq!(
            g.wi_list().len() * g.wo_list().len(),
            g.cells().unwrap() as usize
        );
        let g = Grid::parse("isotropic", "3,5,7").unwrap();
        assert_eq!(g.wi_list().len() * g.wo_list().len(), 105);
        assert!(Grid::parse("isotropic", "3,5").is_err());
        assert!(Grid::parse("full", "3,0,5,5").is_err());
    }
}
