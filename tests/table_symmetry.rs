//! Reciprocal isotropic tables (docs/design.md §4.5): on the isotropic grid with equal θ axes a
//! reciprocal model's table evaluates the cells with θi index ≤ θo index and copies each into
//! its mirror cell. Checked here: which built-in models the GPU evaluates bit-symmetrically; that
//! the mirrored table is the plain table's upper triangle, bit for bit, reflected (so equal to it
//! wherever the halves were bit-equal already, and within the parity tolerance of §10 at every
//! mirror cell); the evaluation count; that a `.brdf` file is mirrored only when the user says
//! so, and then even where f is not reciprocal; and `lobe table`'s files.

mod common;

use glam::DVec3;
use lobe::brdf::{self, LoadOptions};
use lobe::gpu::Gpu;
use lobe::grid::Grid;
use lobe::model::{Model, ParamSet, Reference};
use lobe::{tolerance, Evaluator};
use std::path::Path;

/// The built-in models whose GPU table holds bit-equal values at (θi, θo, Δφ) and
/// (θo, θi, Δφ) on lavapipe: f does not depend on the directions' order of operations at all
/// (lambert, and smooth_layered's diffuse term: ρ/π) or only through a product of commuting
/// factors (coupled: [1 − (1 − c_i)⁵]·[1 − (1 − c_o)⁵]). The others differ in the last bits
/// (the two orders see differently rounded f32 directions), which is why the mirrored table's
/// lower triangle is not the plain table's there.
const BIT_SYMMETRIC: [&str; 3] = ["lambert", "smooth_layered", "coupled"];

/// The parameter sets checked: every isotropic built-in at its defaults, and gold on the
/// microfacet model with and without Kulla–Conty's multiple scattering and V-cavity masking.
fn sets() -> Vec<ParamSet> {
    let mut sets: Vec<ParamSet> = Model::ALL
        .into_iter()
        .map(ParamSet::defaults)
        .filter(ParamSet::is_isotropic)
        .collect();
    for extra in [
        vec![],
        vec!["multiscatter=kulla_conty".to_string()],
        vec!["masking=v_cavity".to_string(), "fresnel=dielectric".into()],
    ] {
        sets.push(lobe::resolve_params("microfacet", Some("gold"), &extra).unwrap());
    }
    sets
}

/// The plain table (every cell evaluated, [`Evaluator::eval_table`]), in npy order.
fn plain(eval: &Evaluator, params: &ParamSet, grid: &Grid) -> Vec<f32> {
    let mut out = Vec::new();
    eval.eval_table(params, grid, &mut |first, v| {
        assert_eq!(first as usize * 3, out.len(), "chunks arrive in order");
        out.extend_from_slice(v);
        Ok(())
    })
    .expect("plain table");
    out
}

/// The table as `lobe table` makes it ([`Evaluator::eval_table_runs`]), placed run by run, with
/// the evaluations the backend reports. Fails unless every cell arrives exactly once.
fn runs(eval: &Evaluator, params: &ParamSet, grid: &Grid) -> (Vec<f32>, u64) {
    let cells = grid.cells().unwrap() as usize;
    let mut out = vec![f32::NAN; cells * 3];
    let mut seen = vec![0u8; cells];
    let evaluations = eval
        .eval_table_runs(params, grid, &mut |first, v| {
            let first = first as usize;
            out[first * 3..first * 3 + v.len()].copy_from_slice(v);
            seen[first..first + v.len() / 3]
                .iter_mut()
                .for_each(|s| *s += 1);
            Ok(())
        })
        .expect("table by runs");
    if let Some(cell) = seen.iter().position(|&s| s != 1) {
        panic!(
            "{}: cell {cell} arrived {} times",
            params.model().name(),
            seen[cell]
        );
    }
    (out, evaluations)
}

/// n, n, NDPHI of an isotropic grid.
fn sides(grid: &Grid) -> (usize, usize) {
    match *grid {
        Grid::Isotropic {
            n_theta_i, n_dphi, ..
        } => (n_theta_i, n_dphi),
        _ => panic!("an isotropic grid"),
    }
}

/// The RGB bits of cell (i, o, d).
fn bits(t: &[f32], n: usize, nd: usize, i: usize, o: usize, d: usize) -> [u32; 3] {
    let c = ((i * n + o) * nd + d) * 3;
    [t[c].to_bits(), t[c + 1].to_bits(), t[c + 2].to_bits()]
}

/// Cells (i, o, d), o > i, whose bits differ from (o, i, d).
fn asymmetric_cells(t: &[f32], grid: &Grid) -> usize {
    let (n, nd) = sides(grid);
    let mut count = 0;
    for i in 0..n {
        for o in i + 1..n {
            count += (0..nd)
                .filter(|&d| bits(t, n, nd, i, o, d) != bits(t, n, nd, o, i, d))
                .count();
        }
    }
    count
}

/// Asserts that `mirrored` holds, at every cell (a, b, d), the bits of `plain`'s cell
/// (min(a, b), max(a, b), d): the evaluated cell wins, its mirror is a copy.
fn assert_upper_triangle_reflected(label: &str, mirrored: &[f32], plain: &[f32], grid: &Grid) {
    let (n, nd) = sides(grid);
    for a in 0..n {
        for b in 0..n {
            for d in 0..nd {
                let want = bits(plain, n, nd, a.min(b), a.max(b), d);
                assert_eq!(
                    bits(mirrored, n, nd, a, b, d),
                    want,
                    "{label} on {grid:?}: cell ({a}, {b}, {d}) is not the plain table's ({}, {}, {d})",
                    a.min(b),
                    a.max(b)
                );
            }
        }
    }
}

/// n(n + 1)/2 · NDPHI: the cells with θi index ≤ θo index.
fn promised_evaluations(grid: &Grid) -> u64 {
    let (n, nd) = sides(grid);
    (n * (n + 1) / 2 * nd) as u64
}

/// Every mirror cell of `mirrored` against the f64 reference at the cell's own directions
/// (rounded to f32, as the kernel receives them), under the parity tolerance of §10.
fn assert_mirrors_within_parity(params: &ParamSet, mirrored: &[f32], grid: &Grid) {
    let (n, nd) = sides(grid);
    let p32 = params.rounded_to_f32();
    let reference = Reference::new(&p32, false);
    let f32_round = |v: DVec3| DVec3::new(v.x as f32 as f64, v.y as f32 as f64, v.z as f32 as f64);
    for i in 1..n {
        for o in 0..i {
            for d in 0..nd {
                let cell = ((i * n + o) * nd + d) as u64;
                let (wi, wo) = grid.pair_at(cell);
                let (wi, wo) = (f32_round(wi), f32_round(wo));
                let c = reference.eval(wi, wo);
                let allowed = tolerance::parity_tolerance(&p32, &reference, wi, wo, c);
                for ch in 0..3 {
                    let got = mirrored[cell as usize * 3 + ch] as f64;
                    assert!(
                        (got - c[ch]).abs() <= allowed[ch],
                        "{} {}: mirror cell ({i}, {o}, {d}) channel {ch}: table {got:e}, \
                         reference {:e}, |diff| {:e} > allowed {:e}",
                        params.model().name(),
                        params.to_text(),
                        c[ch],
                        (got - c[ch]).abs(),
                        allowed[ch]
                    );
                }
            }
        }
    }
}

#[test]
fn the_gpu_evaluates_the_models_named_bit_symmetrically() {
    common::on_gpu(
        "the_gpu_evaluates_the_models_named_bit_symmetrically",
        false,
        |gpu| {
            let grid = Grid::parse("isotropic", "24,24,16").unwrap();
            for params in sets() {
                let name = params.model().name();
                let asymmetric =
                    asymmetric_cells(&plain(&Evaluator::gpu(gpu), &params, &grid), &grid);
                eprintln!(
                    "{name} {}: {asymmetric} cells differ from their mirror",
                    params.to_text()
                );
                if BIT_SYMMETRIC.contains(&name) {
                    assert_eq!(asymmetric, 0, "{name}: the plain table's halves differ");
                }
            }
        },
    );
}

/// Odd sizes (rows end inside an invocation, the last invocation is padded) and one θ cell.
fn mirrored_equals_reflected_plain(gpu: &Gpu) {
    let eval = Evaluator::gpu(gpu);
    for grid in ["9,9,7", "5,5,1", "1,1,3"] {
        let grid = Grid::parse("isotropic", grid).unwrap();
        for params in sets() {
            let label = format!("{} {}", params.model().name(), params.to_text());
            let before = plain(&eval, &params, &grid);
            let (after, evaluations) = runs(&eval, &params, &grid);
            assert_eq!(evaluations, promised_evaluations(&grid), "{label}");
            assert_upper_triangle_reflected(&label, &after, &before, &grid);
            if BIT_SYMMETRIC.contains(&params.model().name()) {
                let same = before
                    .iter()
                    .zip(&after)
                    .all(|(a, b)| a.to_bits() == b.to_bits());
                assert!(same, "{label}: not byte-equal to the plain table");
            }
            assert_mirrors_within_parity(&params, &after, &grid);
        }
    }
}

#[test]
fn a_reciprocal_table_is_the_plain_upper_triangle_reflected() {
    common::on_gpu(
        "a_reciprocal_table_is_the_plain_upper_triangle_reflected",
        false,
        mirrored_equals_reflected_plain,
    );
}

/// The same with a GPU's kernel choices (4 cells per invocation, storage-buffer direction
/// lists), which a CPU driver would otherwise never run.
#[test]
fn with_a_gpus_kernel_choices_a_reciprocal_table_is_the_plain_one_reflected() {
    common::on_gpu(
        "with_a_gpus_kernel_choices_a_reciprocal_table_is_the_plain_one_reflected",
        true,
        mirrored_equals_reflected_plain,
    );
}

#[test]
fn a_table_of_several_chunks_is_the_plain_one_reflected() {
    common::on_gpu_in_chunks(
        "a_table_of_several_chunks_is_the_plain_one_reflected",
        false,
        1 << 20,
        |gpu| {
            // 1.2e6 cells, 6.0e5 evaluated: several 1 MiB chunks, so chunks start inside rows
            // and Δφ runs. With
            // NDPHI = 256 every row starts on an invocation (the kernel's ROW_ALIGNED), and the
            // last chunk ends inside a workgroup (its padding stays on the last row).
            let params = lobe::resolve_params("cook_torrance", None, &[]).unwrap();
            let eval = Evaluator::gpu(gpu);
            for grid in ["67,67,263", "70,70,256"] {
                let grid = Grid::parse("isotropic", grid).unwrap();
                let before = plain(&eval, &params, &grid);
                let (after, evaluations) = runs(&eval, &params, &grid);
                assert_eq!(evaluations, promised_evaluations(&grid));
                assert_upper_triangle_reflected("cook_torrance", &after, &before, &grid);
                assert_mirrors_within_parity(&params, &after, &grid);
            }
        },
    );
}

#[test]
fn other_grids_and_the_cpu_reference_evaluate_every_cell() {
    let params = lobe::resolve_params("cook_torrance", None, &[]).unwrap();
    // The CPU reference: every cell from its own directions, in order.
    let grid = Grid::parse("isotropic", "6,6,5").unwrap();
    let (after, evaluations) = runs(&Evaluator::cpu(), &params, &grid);
    assert_eq!(evaluations, grid.cells().unwrap());
    assert_eq!(after, plain(&Evaluator::cpu(), &params, &grid));
    common::on_gpu(
        "other_grids_and_the_cpu_reference_evaluate_every_cell",
        false,
        |gpu| {
            for grid in ["6,7,5", "7,6,5"] {
                let grid = Grid::parse("isotropic", grid).unwrap();
                let (after, evaluations) = runs(&Evaluator::gpu(gpu), &params, &grid);
                assert_eq!(evaluations, grid.cells().unwrap(), "{grid:?}");
                assert_eq!(
                    after,
                    plain(&Evaluator::gpu(gpu), &params, &grid),
                    "{grid:?}"
                );
            }
        },
    );
}

/// A `.brdf` shader that is not reciprocal: red is cos θi, green cos θo.
const NOT_RECIPROCAL: &str = "# f = (cos theta_i, cos theta_o, 1) / pi: not reciprocal.
analytic

::begin parameters
float scale 0 2 1
::end parameters

::begin shader
vec3 BRDF( vec3 L, vec3 V, vec3 N, vec3 X, vec3 Y )
{
    return scale * vec3(dot(N, L), dot(N, V), 1.0) / 3.14159265;
}
::end shader
";

fn not_reciprocal_file(dir: &Path) -> std::path::PathBuf {
    let path = dir.join("not_reciprocal.brdf");
    std::fs::write(&path, NOT_RECIPROCAL).unwrap();
    path
}

#[test]
fn a_brdf_file_is_mirrored_only_when_declared_reciprocal() {
    common::on_gpu(
        "a_brdf_file_is_mirrored_only_when_declared_reciprocal",
        false,
        |gpu| {
            let dir = tempfile::tempdir().unwrap();
            let path = not_reciprocal_file(dir.path());
            let model = brdf::load(&path, &LoadOptions::default()).unwrap().model;
            assert!(!model.is_reciprocal());
            let params = ParamSet::defaults(model);
            let grid = Grid::parse("isotropic", "7,7,3").unwrap();
            let eval = Evaluator::gpu(gpu);
            let before = plain(&eval, &params, &grid);
            assert!(
                asymmetric_cells(&before, &grid) > 0,
                "the test model is reciprocal"
            );

            let (undeclared, evaluations) = runs(&eval, &params, &grid);
            assert_eq!(evaluations, grid.cells().unwrap());
            assert_eq!(
                undeclared, before,
                "not declared reciprocal, yet not the plain table"
            );

            let declared = eval.assuming_reciprocity(true);
            let (mirrored, evaluations) = runs(&declared, &params, &grid);
            assert_eq!(evaluations, promised_evaluations(&grid));
            assert_upper_triangle_reflected("not_reciprocal.brdf", &mirrored, &before, &grid);
        },
    );
}

fn lobe_table(args: &[&str]) {
    let (code, _, stderr) = common::lobe_run(args);
    assert_eq!(code, 0, "lobe {}: {stderr}", args.join(" "));
}

#[test]
fn lobe_table_writes_the_mirrored_table_and_takes_reciprocal_for_brdf_files() {
    let Some(session) = common::gpu_session("lobe_table_writes_the_mirrored_table") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name).to_string_lossy().into_owned();
    let iso = ["--grid", "isotropic", "--res", "9,9,5"];
    let grid = Grid::parse("isotropic", "9,9,5").unwrap();

    // A built-in model: the npy and the EXR hold the mirrored table, run by run in place.
    lobe_table(
        &[
            &["table", "--model", "cook_torrance", "-o", &out("ct.exr")][..],
            &iso,
        ]
        .concat(),
    );
    let params = lobe::resolve_params("cook_torrance", None, &[]).unwrap();
    let (want, _) = runs(&session.evaluator(), &params, &grid);
    let npy = lobe::table::read_npy(&dir.path().join("ct.npy")).unwrap();
    assert_eq!(npy.shape, vec![9, 9, 5, 3]);
    assert_eq!(npy.values, want);
    assert_eq!(
        lobe::table::read_exr(&dir.path().join("ct.exr"))
            .unwrap()
            .values,
        want
    );

    // A .brdf file: plain without --reciprocal, mirrored with it.
    let file = not_reciprocal_file(dir.path());
    let file = file.to_string_lossy();
    lobe_table(
        &[
            &["table", "--model", &file, "-o", &out("plain.exr")][..],
            &iso,
        ]
        .concat(),
    );
    lobe_table(
        &[
            &[
                "table",
                "--model",
                &file,
                "--reciprocal",
                "-o",
                &out("mirrored.exr"),
            ][..],
            &iso,
        ]
        .concat(),
    );
    let plain = lobe::table::read_npy(&dir.path().join("plain.npy"))
        .unwrap()
        .values;
    let mirrored = lobe::table::read_npy(&dir.path().join("mirrored.npy"))
        .unwrap()
        .values;
    assert!(asymmetric_cells(&plain, &grid) > 0);
    assert_upper_triangle_reflected("--reciprocal", &mirrored, &plain, &grid);
}

/// A MERL table is reciprocal by construction (it is looked up by half and difference angles,
/// which swapping ωi and ωo leaves as they are up to φd → φd + π, folded into [0, π)): its
/// table is mirrored without being asked.
#[test]
fn a_merl_table_is_mirrored() {
    common::on_gpu("a_merl_table_is_mirrored", false, |gpu| {
        // Stored values that differ from bin to bin, so that a cell shows which bin it read.
        let values = (0..3 * lobe::merl::BINS)
            .map(|k| 0.01 + (k % 977) as f64 * 1e-3)
            .collect();
        let table = lobe::merl::MerlTable { values, missing: 0 };
        let model = lobe::merl::model::register("symmetry_test_merl", "bins", table).unwrap();
        assert!(model.is_reciprocal());
        let params = ParamSet::defaults(model);
        let grid = Grid::parse("isotropic", "8,8,6").unwrap();
        let eval = Evaluator::gpu(gpu);
        let before = plain(&eval, &params, &grid);
        let (after, evaluations) = runs(&eval, &params, &grid);
        assert_eq!(evaluations, promised_evaluations(&grid));
        assert_upper_triangle_reflected("merl", &after, &before, &grid);
    });
}

/// n_θh · n_θd rows of NPHI_D cells, and NPHI_D of a three-axis half/difference grid.
fn halfdiff_rows(grid: &Grid) -> (usize, usize) {
    match *grid {
        Grid::HalfDiff {
            n_theta_h,
            n_theta_d,
            n_phi_d,
        } => (n_theta_h * n_theta_d, n_phi_d),
        _ => panic!("a three-axis halfdiff grid"),
    }
}

/// Asserts that every cell (row, k) of `mirrored` holds the bits of `plain`'s cell
/// (row, min(k, NPHI_D − 1 − k)).
fn assert_phi_d_reflected(label: &str, mirrored: &[f32], plain: &[f32], grid: &Grid) {
    let (rows, n) = halfdiff_rows(grid);
    for r in 0..rows {
        for k in 0..n {
            let (cell, from) = ((r * n + k) * 3, (r * n + k.min(n - 1 - k)) * 3);
            let want: Vec<u32> = plain[from..from + 3].iter().map(|x| x.to_bits()).collect();
            let got: Vec<u32> = mirrored[cell..cell + 3]
                .iter()
                .map(|x| x.to_bits())
                .collect();
            assert_eq!(got, want, "{label} on {grid:?}: row {r}, φd cell {k}");
        }
    }
}

/// f(θh, θd, φd) = f(θh, θd, π − φd) (reciprocity: φd → φd + π; isotropy: φd → −φd): the
/// cells k ≤ NPHI_D − 1 − k are evaluated, each copied to NPHI_D − 1 − k, and every copy is
/// within the parity tolerance of the reference at its own directions.
#[test]
fn a_reciprocal_halfdiff_table_mirrors_phi_d() {
    common::on_gpu("a_reciprocal_halfdiff_table_mirrors_phi_d", false, |gpu| {
        let eval = Evaluator::gpu(gpu);
        for grid in ["5,4,7", "3,3,6", "2,2,1"] {
            let grid = Grid::parse("halfdiff", grid).unwrap();
            let (rows, n) = halfdiff_rows(&grid);
            for params in sets() {
                let label = format!("{} {}", params.model().name(), params.to_text());
                let before = plain(&eval, &params, &grid);
                let (after, evaluations) = runs(&eval, &params, &grid);
                assert_eq!(evaluations, (rows * n.div_ceil(2)) as u64, "{label}");
                assert_phi_d_reflected(&label, &after, &before, &grid);
                let p32 = params.rounded_to_f32();
                let reference = Reference::new(&p32, false);
                let f32_round =
                    |v: DVec3| DVec3::new(v.x as f32 as f64, v.y as f32 as f64, v.z as f32 as f64);
                for cell in 0..grid.cells().unwrap() {
                    let (wi, wo) = grid.pair_at(cell);
                    let (wi, wo) = (f32_round(wi), f32_round(wo));
                    let c = reference.eval(wi, wo);
                    let allowed = tolerance::parity_tolerance(&p32, &reference, wi, wo, c);
                    for ch in 0..3 {
                        let got = after[cell as usize * 3 + ch] as f64;
                        assert!(
                            (got - c[ch]).abs() <= allowed[ch],
                            "{label}: cell {cell} channel {ch}: table {got:e}, reference {:e}, \
                             allowed {:e}",
                            c[ch],
                            allowed[ch]
                        );
                    }
                }
            }
        }
    });
}

#[test]
fn a_halfdiff_table_of_a_brdf_file_or_on_the_cpu_evaluates_every_cell() {
    let grid = Grid::parse("halfdiff", "3,4,5").unwrap();
    let params = lobe::resolve_params("cook_torrance", None, &[]).unwrap();
    let (after, evaluations) = runs(&Evaluator::cpu(), &params, &grid);
    assert_eq!(evaluations, grid.cells().unwrap());
    assert_eq!(after, plain(&Evaluator::cpu(), &params, &grid));
    common::on_gpu(
        "a_halfdiff_table_of_a_brdf_file_evaluates_every_cell",
        false,
        |gpu| {
            let dir = tempfile::tempdir().unwrap();
            let model = brdf::load(&not_reciprocal_file(dir.path()), &LoadOptions::default())
                .unwrap()
                .model;
            let params = ParamSet::defaults(model);
            let eval = Evaluator::gpu(gpu);
            let before = plain(&eval, &params, &grid);
            let (undeclared, evaluations) = runs(&eval, &params, &grid);
            assert_eq!(evaluations, grid.cells().unwrap());
            assert_eq!(undeclared, before);
            let (mirrored, evaluations) = runs(&eval.assuming_reciprocity(true), &params, &grid);
            assert_eq!(evaluations, 3 * 4 * 3);
            assert_phi_d_reflected("not_reciprocal.brdf", &mirrored, &before, &grid);
        },
    );
}

/// The parameter sets checked on the full grid: every built-in at its defaults, and the
/// anisotropic ones, where the mirror symmetries are not those of isotropy.
fn full_grid_sets() -> Vec<ParamSet> {
    let mut sets: Vec<ParamSet> = Model::ALL.into_iter().map(ParamSet::defaults).collect();
    for (model, extra) in [
        ("microfacet", vec!["alpha_x=0.08", "alpha_y=0.5"]),
        (
            "microfacet",
            vec![
                "distribution=beckmann",
                "alpha_x=0.5",
                "alpha_y=0.1",
                "multiscatter=kulla_conty",
            ],
        ),
        ("ashikhmin_shirley", vec!["nu=2000", "nv=20"]),
    ] {
        let extra: Vec<String> = extra.into_iter().map(String::from).collect();
        sets.push(lobe::resolve_params(model, Some("gold"), &extra).unwrap());
    }
    sets
}

/// (NTHETA_I, NPHI_I, NTHETA_O, NPHI_O) of a full grid.
fn full_sides(grid: &Grid) -> [usize; 4] {
    match *grid {
        Grid::Full {
            n_theta_i,
            n_phi_i,
            n_theta_o,
            n_phi_o,
        } => [n_theta_i, n_phi_i, n_theta_o, n_phi_o],
        _ => panic!("a full grid"),
    }
}

/// Asserts that `copied` holds the plain table's bits wherever φi lies in the first quadrant
/// (the evaluated cells), and everywhere else a value within the parity tolerance of §10 of
/// the f64 reference at the cell's own directions (rounded to f32, as the kernel receives
/// them). Returns the cells outside the first quadrant whose bits equal the plain table's.
fn assert_quadrants_copied(params: &ParamSet, copied: &[f32], plain: &[f32], grid: &Grid) -> usize {
    let [nti, npi, nto, npo] = full_sides(grid);
    let label = format!("{} {} on {grid:?}", params.model().name(), params.to_text());
    let row = nto * npo;
    let p32 = params.rounded_to_f32();
    let reference = Reference::new(&p32, false);
    let f32_round = |v: DVec3| DVec3::new(v.x as f32 as f64, v.y as f32 as f64, v.z as f32 as f64);
    let mut same_bits = 0;
    for ti in 0..nti {
        for a in 0..npi {
            for v in 0..row {
                let cell = (ti * npi + a) * row + v;
                let (got, want) = (
                    &copied[cell * 3..cell * 3 + 3],
                    &plain[cell * 3..cell * 3 + 3],
                );
                let equal = got
                    .iter()
                    .zip(want)
                    .all(|(g, w)| g.to_bits() == w.to_bits());
                if a < npi / 4 {
                    assert!(
                        equal,
                        "{label}: evaluated cell {cell} is not the plain table's"
                    );
                    continue;
                }
                same_bits += equal as usize;
                let (wi, wo) = grid.pair_at(cell as u64);
                let (wi, wo) = (f32_round(wi), f32_round(wo));
                let c = reference.eval(wi, wo);
                let allowed = tolerance::parity_tolerance(&p32, &reference, wi, wo, c);
                for ch in 0..3 {
                    assert!(
                        (got[ch] as f64 - c[ch]).abs() <= allowed[ch],
                        "{label}: copied cell {cell} (theta_i {ti}, phi_i {a}, view {v}) channel \
                         {ch}: table {:e}, reference {:e}, allowed {:e}",
                        got[ch],
                        c[ch],
                        allowed[ch]
                    );
                }
            }
        }
    }
    same_bits
}

/// Grids whose φ axes hold whole quadrants (NPHI_I a multiple of 4, NPHI_O even), one light
/// cell per quadrant among them, and a view axis whose cells φo = π/2 ± … pair up across x = 0.
fn full_tables_copy_three_quarters(gpu: &Gpu) {
    let eval = Evaluator::gpu(gpu);
    for grid in ["3,8,4,6", "2,4,3,2", "4,12,3,10"] {
        let grid = Grid::parse("full", grid).unwrap();
        for params in full_grid_sets() {
            let before = plain(&eval, &params, &grid);
            let (after, evaluations) = runs(&eval, &params, &grid);
            assert_eq!(evaluations * 4, grid.cells().unwrap(), "{grid:?}");
            let same = assert_quadrants_copied(&params, &after, &before, &grid);
            eprintln!(
                "{} {} on {grid:?}: {same} of {} copied cells bit-equal to the plain table",
                params.model().name(),
                params.to_text(),
                grid.cells().unwrap() * 3 / 4
            );
        }
    }
}

#[test]
fn a_mirror_symmetric_full_table_evaluates_a_quarter() {
    common::on_gpu(
        "a_mirror_symmetric_full_table_evaluates_a_quarter",
        false,
        full_tables_copy_three_quarters,
    );
}

#[test]
fn with_a_gpus_kernel_choices_a_full_table_evaluates_a_quarter() {
    common::on_gpu(
        "with_a_gpus_kernel_choices_a_full_table_evaluates_a_quarter",
        true,
        full_tables_copy_three_quarters,
    );
}

/// Several 1 MiB chunks: 590k cells evaluated, chunks that start inside a light row and inside
/// a view block.
#[test]
fn a_full_table_of_several_chunks_evaluates_a_quarter() {
    common::on_gpu_in_chunks(
        "a_full_table_of_several_chunks_evaluates_a_quarter",
        false,
        1 << 20,
        |gpu| {
            let grid = Grid::parse("full", "24,64,24,64").unwrap();
            let params =
                lobe::resolve_params("microfacet", Some("gold"), &["alpha_x=0.1".into()]).unwrap();
            let eval = Evaluator::gpu(gpu);
            let before = plain(&eval, &params, &grid);
            let (after, evaluations) = runs(&eval, &params, &grid);
            assert_eq!(evaluations * 4, grid.cells().unwrap());
            assert_quadrants_copied(&params, &after, &before, &grid);
        },
    );
}

/// Where the φ axes do not hold whole quadrants, for a `.brdf` file (not declared mirror
/// symmetric, reciprocal or not) and on the CPU reference, every cell is evaluated.
#[test]
fn other_full_tables_evaluate_every_cell() {
    let params = lobe::resolve_params("cook_torrance", None, &[]).unwrap();
    let grid = Grid::parse("full", "3,8,3,6").unwrap();
    let (after, evaluations) = runs(&Evaluator::cpu(), &params, &grid);
    assert_eq!(evaluations, grid.cells().unwrap());
    assert_eq!(after, plain(&Evaluator::cpu(), &params, &grid));
    common::on_gpu("other_full_tables_evaluate_every_cell", false, |gpu| {
        let eval = Evaluator::gpu(gpu);
        for grid in ["3,6,3,6", "3,8,3,5"] {
            let grid = Grid::parse("full", grid).unwrap();
            let (after, evaluations) = runs(&eval, &params, &grid);
            assert_eq!(evaluations, grid.cells().unwrap(), "{grid:?}");
            assert_eq!(after, plain(&eval, &params, &grid), "{grid:?}");
        }
        let dir = tempfile::tempdir().unwrap();
        let model = brdf::load(&not_reciprocal_file(dir.path()), &LoadOptions::default())
            .unwrap()
            .model;
        let params = ParamSet::defaults(model);
        let grid = Grid::parse("full", "3,8,3,6").unwrap();
        for eval in [eval.clone(), eval.assuming_reciprocity(true)] {
            let (after, evaluations) = runs(&eval, &params, &grid);
            assert_eq!(evaluations, grid.cells().unwrap());
            assert_eq!(after, plain(&eval, &params, &grid));
        }
    });
}
