//! Opens a session (a Vulkan device, or the f64 CPU reference with `--cpu`), tabulates gold's
//! Cook–Torrance lobe on a small isotropic grid and prints its directional albedo.
//!     cargo run --release --example session [-- --cpu]
use lobe::{grid::Grid, model::ParamSet, AlbedoSettings, BackendKind, Session, SessionOptions};

fn main() -> lobe::Result<()> {
    let cpu = std::env::args().any(|a| a == "--cpu");
    let backend = if cpu {
        BackendKind::Cpu
    } else {
        BackendKind::Gpu
    };
    let session = Session::open(SessionOptions {
        backend,
        ..Default::default()
    })?;
    let gold = ParamSet::preset("gold", "cook_torrance")?.with("roughness", 0.2)?;
    let grid = Grid::Isotropic {
        n_theta_i: 16,
        n_theta_o: 16,
        n_dphi: 32,
    };
    let table = session.table(&gold, &grid, 1 << 20)?;
    let peak = table.data().chunks(3).map(|c| c[0]).fold(0.0, f32::max);
    println!(
        "{}: {} cells, peak f (red) {peak:.3}/sr, f at the first cell {:?}",
        session.backend_name(),
        table.cells(),
        table.at(&[0, 0, 0])
    );
    let points = [(0.5, 0.0), (1.0, 0.0)];
    for e in session.directional_albedo(&gold, &AlbedoSettings::default(), &points)? {
        println!(
            "E(mu = {}) = {:.6?} ± {:.1e}",
            e.mu,
            e.albedo.to_array(),
            e.error.max_element()
        );
    }
    Ok(())
}
