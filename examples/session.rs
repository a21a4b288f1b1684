//! Opens a session (a Vulkan device, or the f64 CPU reference with `--cpu`), evaluates gold's
//! Cook–Torrance lobe on a small isotropic table and prints its directional albedo.
//!     cargo run --release --example session [-- --cpu]
use lobe::grid::Grid;
use lobe::{AlbedoSettings, BackendKind, Session, SessionOptions};

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
    let gold = lobe::resolve_params("cook_torrance", Some("gold"), &[])?;
    let grid = Grid::Isotropic {
        n_theta_i: 16,
        n_theta_o: 16,
        n_dphi: 32,
    };
    let table = session.table(&gold, false, &grid, 1 << 20)?;
    let peak = table.chunks(3).map(|c| c[0]).fold(0.0f32, f32::max);
    println!(
        "{}: {} cells, largest f (red) {peak:.3} 1/sr",
        session.backend_name(),
        table.len() / 3
    );
    let e =
        session.directional_albedo(&gold, &AlbedoSettings::default(), &[(0.5, 0.0), (1.0, 0.0)])?;
    for p in &e {
        println!(
            "E(mu = {}) = {:.6?} (error estimate {:.1e})",
            p.mu,
            p.albedo,
            p.error.max_element()
        );
    }
    Ok(())
}
