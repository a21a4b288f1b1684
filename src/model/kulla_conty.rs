//! Kulla & Conty's multiple-scattering lobe for the microfacet model (Kulla & Conty 2017,
//! "Revisiting physically based shading at Imageworks", SIGGRAPH course notes):
//! f_ms = F_ms (1 − E(μo))(1 − E(μi)) / (π (1 − E_avg)), with E(μ; α) the directional albedo of
//! the same microfacet lobe (distribution, masking) under F = 1, E_avg = 2∫₀¹ E(μ) μ dμ, and
//! F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg)), F_avg = 2∫₀¹ F(μ) μ dμ.
//!
//! The tables are lobe's own (`data/kulla_conty.txt`, written by `scripts/kulla-conty-tables`
//! with `lobe albedo --backend cpu --white-furnace`, the f64 reference with its peak rule): the
//! loss L = 1 − E at s = √μ = j/64 and r = √α = k/64, j, k = 1 … 64, for each of
//! [`TABLES`]. The row r = 0 is 0 (a mirror loses nothing) and the column s = 0 is the cubic
//! extrapolation 4L₁ − 6L₂ + 4L₃ − L₄ of its row, so each table has 65 × 65 knots; the knots are
//! kept as f32, the values the GPU reads, so that both twins interpolate the same numbers.
//!
//! Interpolation, the same on both sides (twin: `kc_loss` in `glsl/brdf/kulla_conty.glsl`):
//! 4-point Lagrange in s and in r on the uniform knots, the stencil of interval m being knots
//! clamp(m − 1, 0, 61) … + 3 (a piecewise cubic), tensor product in (s, r). The average row
//! L_avg(r_k) = 4∫₀¹ L̃_k(s) s³ ds is the exact integral of row k's piecewise cubic (4-point
//! Gauss–Legendre per interval, exact for its degree 6), interpolated in r with the same
//! weights; so L_avg(α) = 2∫ L̃(μ; α) μ dμ exactly, and under F = 1 the lobe's albedo is
//! E(μo) + L̃(μo): one up to the interpolation error of L̃. Anisotropic roughness looks the
//! tables up at √(αx αy).

use super::components::{BeckmannG1, MicrofacetConfig};
use std::sync::OnceLock;

/// Knots per axis: s = √μ and r = √α at j/64, j = 0 … 64.
pub const KNOTS: usize = 65;

/// The tables, as (distribution, masking, Beckmann G1) option names, in the order of the
/// shipped file and of [`table_index`]. GGX and V-cavity masking do not use the G1 choice.
pub const TABLES: [(&str, &str, &str); 8] = [
    ("beckmann", "v_cavity", "exact"),
    ("beckmann", "smith_separable", "exact"),
    ("beckmann", "smith_separable", "rational"),
    ("beckmann", "smith_correlated", "exact"),
    ("beckmann", "smith_correlated", "rational"),
    ("ggx", "v_cavity", "exact"),
    ("ggx", "smith_separable", "exact"),
    ("ggx", "smith_correlated", "exact"),
];

/// The shipped tables (see the module documentation and the file's own header).
pub const DATA: &str = include_str!("../../data/kulla_conty.txt");

/// One table: the loss at the knots and the average of each row.
#[derive(Clone, Debug)]
pub struct Table {
    /// L = 1 − E at (s_j, r_k), index k·[`KNOTS`] + j, as f32 (the GPU's values).
    pub loss: Vec<f32>,
    /// L_avg(r_k) = 4∫ L̃_k(s) s³ ds of each row's interpolant, in f64.
    pub avg: Vec<f64>,
    /// The largest error estimate of the integrator over the table's entries.
    pub largest_error: f64,
    /// The block bound at the model's data binding: `loss`, then `avg` rounded to f32.
    pub gpu: Vec<u8>,
}

/// Which table a configuration reads (an index into [`TABLES`]).
pub fn table_index(c: MicrofacetConfig) -> usize {
    let g1 = if c.uses_beckmann_g1() {
        c.beckmann_g1
    } else {
        BeckmannG1::Exact
    };
    let key = (c.distribution.name(), c.masking.name(), g1.name());
    TABLES
        .iter()
        .position(|t| *t == key)
        .expect("every configuration has a table")
}

/// The tables parsed from [`DATA`], built once.
pub fn tables() -> &'static [Table] {
    static T: OnceLock<Vec<Table>> = OnceLock::new();
    T.get_or_init(|| parse(DATA).expect("data/kulla_conty.txt is well formed (tested)"))
}

/// Reads the tables' text: `knots N`, then one line per row, `D M G1 k ERROR L_1 … L_N`.
pub fn parse(text: &str) -> Result<Vec<Table>, String> {
    let n = KNOTS - 1;
    let mut rows: Vec<Vec<Option<Vec<f64>>>> = vec![vec![None; n]; TABLES.len()];
    let mut errors = [0.0f64; TABLES.len()];
    let mut knots_seen = false;
    for (line_no, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let bad = |what: &str| format!("data/kulla_conty.txt line {}: {what}", line_no + 1);
        let f: Vec<&str> = line.split_whitespace().collect();
        if f[0] == "knots" {
            if f.get(1) != Some(&n.to_string().as_str()) {
                return Err(bad(&format!("expected 'knots {n}'")));
            }
            knots_seen = true;
            continue;
        }
        if f.len() != 5 + n {
            return Err(bad(&format!(
                "expected {} fields, found {}",
                5 + n,
                f.len()
            )));
        }
        let t = TABLES
            .iter()
            .position(|t| *t == (f[0], f[1], f[2]))
            .ok_or_else(|| bad("unknown table"))?;
        let k: usize = f[3].parse().map_err(|_| bad("row index"))?;
        if !(1..=n).contains(&k) {
            return Err(bad("row index out of range"));
        }
        let num = |s: &str| s.parse::<f64>().map_err(|_| bad(&format!("number '{s}'")));
        errors[t] = errors[t].max(num(f[4])?);
        let values = f[5..]
            .iter()
            .map(|s| num(s))
            .collect::<Result<Vec<_>, _>>()?;
        rows[t][k - 1] = Some(values);
    }
    if !knots_seen {
        return Err("data/kulla_conty.txt: no 'knots' line".into());
    }
    let mut out = Vec::new();
    for (t, table_rows) in rows.into_iter().enumerate() {
        let mut loss = vec![0.0f32; KNOTS * KNOTS];
        for (k, row) in table_rows.into_iter().enumerate() {
            let row = row.ok_or_else(|| {
                format!(
                    "data/kulla_conty.txt: table {:?} lacks row {}",
                    TABLES[t],
                    k + 1
                )
            })?;
            let base = (k + 1) * KNOTS;
            for (j, v) in row.iter().enumerate() {
                loss[base + j + 1] = *v as f32;
            }
            let l = |j: usize| loss[base + j] as f64;
            loss[base] = (4.0 * l(1) - 6.0 * l(2) + 4.0 * l(3) - l(4)) as f32;
        }
        let avg: Vec<f64> = (0..KNOTS)
            .map(|k| row_average(&loss[k * KNOTS..][..KNOTS]))
            .collect();
        let mut gpu: Vec<u8> = Vec::with_capacity(4 * (loss.len() + avg.len()));
        gpu.extend(loss.iter().flat_map(|v| v.to_le_bytes()));
        gpu.extend(avg.iter().flat_map(|v| (*v as f32).to_le_bytes()));
        out.push(Table {
            loss,
            avg,
            largest_error: errors[t],
            gpu,
        });
    }
    Ok(out)
}

/// 4-point Lagrange weights at u ∈ [0, 64] on the knots 0 … 64: (first knot, weights).
pub fn lagrange(u: f64) -> (usize, [f64; 4]) {
    let u = u.clamp(0.0, (KNOTS - 1) as f64);
    let i0 = (u.floor() as usize).saturating_sub(1).min(KNOTS - 4);
    let t = u - i0 as f64;
    (
        i0,
        [
            -(t - 1.0) * (t - 2.0) * (t - 3.0) / 6.0,
            t * (t - 2.0) * (t - 3.0) / 2.0,
            -t * (t - 1.0) * (t - 3.0) / 2.0,
            t * (t - 1.0) * (t - 2.0) / 6.0,
        ],
    )
}

/// 4∫₀¹ L̃(s) s³ ds of one row's piecewise cubic, by 4-point Gauss–Legendre per interval.
fn row_average(row: &[f32]) -> f64 {
    // Gauss–Legendre nodes and weights on [0, 1] (Abramowitz & Stegun table 25.4, n = 4).
    let a = 0.5 * 0.861_136_311_594_052_6;
    let b = 0.5 * 0.339_981_043_584_856_3;
    let wa = 0.5 * 0.347_854_845_137_453_9;
    let wb = 0.5 * 0.652_145_154_862_546_1;
    let rule = [(0.5 - a, wa), (0.5 - b, wb), (0.5 + b, wb), (0.5 + a, wa)];
    let n = (KNOTS - 1) as f64;
    let mut sum = 0.0;
    for m in 0..KNOTS - 1 {
        for &(x, w) in &rule {
            let u = m as f64 + x;
            let (i0, wts) = lagrange(u);
            let l: f64 = (0..4).map(|q| wts[q] * row[i0 + q] as f64).sum();
            let s = u / n;
            sum += w * l * s * s * s;
        }
    }
    4.0 * sum / n
}

impl Table {
    /// L̃(μ; α) = 1 − E, interpolated (clamped at 0: the integrator's E may exceed 1 by its
    /// error where the loss vanishes).
    pub fn loss_at(&self, mu: f64, alpha: f64) -> f64 {
        let n = (KNOTS - 1) as f64;
        let (j0, wj) = lagrange(mu.max(0.0).sqrt() * n);
        let (k0, wk) = lagrange(alpha.max(0.0).sqrt() * n);
        let mut sum = 0.0;
        for (a, wa) in wk.iter().enumerate() {
            let row = &self.loss[(k0 + a) * KNOTS + j0..][..4];
            let l: f64 = (0..4).map(|b| wj[b] * row[b] as f64).sum();
            sum += wa * l;
        }
        sum.max(0.0)
    }

    /// L_avg(α) = 1 − E_avg, interpolated in r = √α with the weights of [`Table::loss_at`].
    pub fn avg_at(&self, alpha: f64) -> f64 {
        let (k0, wk) = lagrange(alpha.max(0.0).sqrt() * (KNOTS - 1) as f64);
        (0..4).map(|a| wk[a] * self.avg[k0 + a]).sum()
    }
}

/// The multiple-scattering factor (1 − E(μo))(1 − E(μi)) / (π (1 − E_avg)) of `table` at
/// roughness `alpha` (√(αx αy) for an anisotropic lobe), and 1 − E_avg; 0 where 1 − E_avg is 0.
pub fn lobe(table: &Table, mu_i: f64, mu_o: f64, alpha: f64) -> (f64, f64) {
    let avg = table.avg_at(alpha);
    if avg <= 0.0 {
        return (0.0, 0.0);
    }
    let l_i = table.loss_at(mu_i, alpha);
    let l_o = table.loss_at(mu_o, alpha);
    (l_o * l_i / (std::f64::consts::PI * avg), avg)
}

/// F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg)), with `avg_loss` = 1 − E_avg: the share of the
/// energy that leaves after any number of bounces, each scaled by F_avg (Kulla & Conty 2017).
pub fn fresnel_ms(f_avg: f64, avg_loss: f64) -> f64 {
    f_avg * f_avg * (1.0 - avg_loss) / (1.0 - f_avg * avg_loss)
}

/// 2∫₀¹ F(μ) μ dμ of a Fresnel factor F, by Gauss–Legendre with 8 points on each of 8 equal
/// intervals of μ (F is smooth on [0, 1] for the exact dielectric with η ≥ 1 and the exact
/// conductor: the rule is then accurate to rounding).
pub fn fresnel_average(f: impl Fn(f64) -> f64) -> f64 {
    static RULE: OnceLock<Vec<(f64, f64)>> = OnceLock::new();
    let rule = RULE.get_or_init(|| crate::quadrature::gauss_legendre(8));
    let panels = 8;
    let h = 1.0 / panels as f64;
    let mut sum = 0.0;
    for p in 0..panels {
        for &(x, w) in rule {
            let mu = h * (p as f64 + 0.5 * (x + 1.0));
            sum += 0.5 * h * w * f(mu) * mu;
        }
    }
    2.0 * sum
}
