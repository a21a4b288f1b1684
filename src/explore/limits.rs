//! The bounds on what one request may ask for. Each keeps one request's work to a fraction of a
//! second on a CPU driver and its answer to a few megabytes, far beyond what a view draws.

/// The longest request target (path and query) accepted, in bytes.
pub const MAX_URI_BYTES: usize = 8 * 1024;

/// The largest request body accepted for a view's parameters (JSON), in bytes.
pub const MAX_BODY_BYTES: usize = 64 * 1024;

/// The largest `.brdf` file the page may open, in bytes: the BRDF Explorer files that ship with
/// it are under 10 KiB.
pub const MAX_BRDF_BYTES: usize = 1024 * 1024;

/// A MERL file opened from the page: the format's one size, 34,992,012 bytes (90 × 90 × 180 bins
/// × 3 channels of f64, and a 12-byte header).
pub const MAX_MERL_BYTES: usize = crate::merl::FILE_BYTES;

/// The largest environment map file the page may open (`POST /api/env`); the map within it is
/// bounded as `lobe light --env FILE` bounds it.
pub const MAX_ENV_BYTES: usize = 64 * 1024 * 1024;

/// Files the page may open in one server's life: each stays loaded (a MERL table is 17 MB as
/// f32 on the device and 35 MB as f64 for the reference), so their number is bounded (models
/// and maps counted apart).
pub const MAX_UPLOADS: usize = 32;

/// View angles of one polar curve: 4096 puts a point every 0.044°.
pub const MAX_POLAR_SAMPLES: usize = 4096;

/// Cells across an image view: the hemisphere, the θh × θd slice, the lit sphere (256 × 256 =
/// 65536 evaluations).
pub const MAX_IMAGE_RES: usize = 256;

/// View directions of one E(μ) curve.
pub const MAX_ALBEDO_POINTS: usize = 64;

/// Assignments (`key=value`) in one request: more than any model has parameters.
pub const MAX_ASSIGNMENTS: usize = 64;

/// Draws of one samples view: 16384 points are more than a 256-pixel disc shows apart, and a
/// few hundred kilobytes of JSON.
pub const MAX_VIEW_DRAWS: usize = 16384;

/// Pixels per side of the lit view's sphere under an environment map: the exact sum visits every
/// texel for every pixel, so its time grows with the square of this.
pub const MAX_LIGHT_SIZE: u32 = 192;
