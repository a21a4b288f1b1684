//! Where a table's largest error estimate lies, and the warning that names it.

/// Where a table's largest error estimate is: the entry, its indices and its axes' values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorEntry {
    /// The estimate, absolute.
    pub error: f64,
    /// The column j and μ_j of an E entry; None for an E_avg entry.
    pub mu: Option<(usize, f64)>,
    /// The row k and the parameter p_k.
    pub p: (usize, f64),
}

impl ErrorEntry {
    /// "E at mu = 0.015625 (column 0), alpha = 0.0002441 (row 0)", with `key` the axis's name.
    pub fn describe(&self, key: &str) -> String {
        let (k, p) = self.p;
        match self.mu {
            Some((j, mu)) => format!("E at mu = {mu} (column {j}), {key} = {p:.7} (row {k})"),
            None => format!("E_avg at {key} = {p:.7} (row {k})"),
        }
    }
}

/// The entry with the largest of `e_error` (E, row-major over `ps` × `mus`) and `avg_error`
/// (E_avg, one per row); None when both are empty.
pub fn largest_entry(
    mus: &[f64],
    ps: &[f64],
    e_error: &[f64],
    avg_error: &[f64],
) -> Option<ErrorEntry> {
    let n_mu = mus.len().max(1);
    let e = e_error.iter().enumerate().map(|(i, &error)| ErrorEntry {
        error,
        mu: Some((i % n_mu, mus[i % n_mu])),
        p: (i / n_mu, ps[i / n_mu]),
    });
    let avg = avg_error.iter().enumerate().map(|(k, &error)| ErrorEntry {
        error,
        mu: None,
        p: (k, ps[k]),
    });
    // A NaN estimate counts as the largest: it is no bound at all.
    e.chain(avg).reduce(|a, b| {
        if b.error > a.error || b.error.is_nan() {
            b
        } else {
            a
        }
    })
}
