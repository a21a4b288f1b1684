//! `lobe eval`: f at direction pairs given on the command line or in a pairs file. A pairs file
//! is streamed: read, evaluated and written a chunk at a time, so memory stays bounded whatever
//! its length.

use super::{open_session, BackendArgs, ModelArgs};
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use lobe::pairs::{self, PairsReader, CHUNK_PAIRS};
use lobe::Query;
use std::io::{BufRead, Write};
use std::path::PathBuf;

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum Format {
    Csv,
    Json,
}

#[derive(Args)]
pub struct EvalArgs {
    #[command(flatten)]
    model: ModelArgs,
    #[command(flatten)]
    backend: BackendArgs,
    /// Light direction wi as THETA,PHI in degrees (theta in [0, 180]; f = 0 below the horizon).
    #[arg(
        long = "wi-deg",
        visible_alias = "wi",
        value_name = "THETA,PHI",
        requires = "wo",
        conflicts_with = "pairs",
        allow_hyphen_values = true
    )]
    wi: Option<String>,
    /// View direction wo as THETA,PHI in degrees.
    #[arg(
        long = "wo-deg",
        visible_alias = "wo",
        value_name = "THETA,PHI",
        requires = "wi",
        allow_hyphen_values = true
    )]
    wo: Option<String>,
    /// CSV file of pairs with the header theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg; `-` reads
    /// standard input. Any length: rows are read, evaluated and written in chunks of 65536.
    #[arg(long, value_name = "FILE.csv")]
    pairs: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Csv)]
    format: Format,
}

/// Where the pairs come from: one pair from the flags, or a pairs file read in chunks.
enum Input {
    One(Option<[f64; 4]>),
    File(PairsReader<Box<dyn BufRead>>),
}

impl Input {
    fn next_chunk(&mut self) -> Result<Vec<[f64; 4]>> {
        match self {
            Input::One(pair) => Ok(pair.take().into_iter().collect()),
            Input::File(reader) => reader.next_chunk(CHUNK_PAIRS),
        }
    }
}

/// One row of the JSON output.
#[derive(serde::Serialize)]
struct JsonRow {
    theta_i_deg: f64,
    phi_i_deg: f64,
    theta_o_deg: f64,
    phi_o_deg: f64,
    rgb: [f64; 3],
}

pub fn run(a: EvalArgs) -> Result<()> {
    let params = a.model.params()?;
    let mut input = match (&a.wi, &a.wo, &a.pairs) {
        (Some(wi), Some(wo), None) => {
            let [ti, pi] = pairs::parse_direction(wi).context("--wi-deg")?;
            let [to, po] = pairs::parse_direction(wo).context("--wo-deg")?;
            Input::One(Some([ti, pi, to, po]))
        }
        (None, None, Some(path)) => {
            let (reader, source): (Box<dyn BufRead>, String) = if path.as_os_str() == "-" {
                (Box::new(std::io::stdin().lock()), "stdin".to_string())
            } else {
                let (file, _) = lobe::input::open_input(path, "pairs file")?;
                (
                    Box::new(std::io::BufReader::new(file)),
                    path.display().to_string(),
                )
            };
            Input::File(PairsReader::new(reader, &source)?)
        }
        _ => bail!("give either --wi-deg THETA,PHI --wo-deg THETA,PHI or --pairs FILE.csv"),
    };
    let session = open_session(&a.backend)?;
    let mut out = std::io::BufWriter::new(super::stdout());
    let head = match a.format {
        Format::Csv => format!("{},r,g,b\n", pairs::HEADER),
        Format::Json => {
            let field = |k: &str, v: serde_json::Value| format!("  \"{k}\": {v},\n");
            [
                "{\n".to_string(),
                field("model", params.model().name().into()),
                field("parameters", params.to_json()),
                field("white_furnace", a.model.white_furnace.into()),
                field("backend", session.backend_name().into()),
                field(
                    "units",
                    "1/sr, linear RGB, without the cosine; delta lobes excluded".into(),
                ),
                "  \"values\": [".to_string(),
            ]
            .concat()
        }
    };
    out.write_all(head.as_bytes())?;
    let mut rows = 0usize;
    let mut text = String::new();
    let mut invalid = lobe::finite::InvalidCount::default();
    loop {
        let angles = input.next_chunk()?;
        if angles.is_empty() {
            break;
        }
        let (values, mut count) = session.eval_pairs_counting(
            Query::one(&params).with_white_furnace(a.model.white_furnace),
            &pairs::directions(&angles),
        )?;
        if let Some(f) = &mut count.first {
            f.index += rows as u64;
        }
        invalid.merge(count);
        text.clear();
        for (&[ti, pi, to, po], &rgb) in angles.iter().zip(&values) {
            match a.format {
                Format::Csv => {
                    let [r, g, b] = rgb;
                    text.push_str(&format!("{ti},{pi},{to},{po},{r},{g},{b}\n"));
                }
                Format::Json => {
                    text.push_str(if rows == 0 { "\n    " } else { ",\n    " });
                    let row = JsonRow {
                        theta_i_deg: ti,
                        phi_i_deg: pi,
                        theta_o_deg: to,
                        phi_o_deg: po,
                        rgb,
                    };
                    text.push_str(&serde_json::to_string(&row)?);
                }
            }
            rows += 1;
        }
        out.write_all(text.as_bytes())?;
    }
    if a.format == Format::Json {
        let tail = if rows == 0 { "]\n}\n" } else { "\n  ]\n}\n" };
        out.write_all(tail.as_bytes())?;
    }
    out.flush()?;
    super::warn_invalid(params.model().name(), &invalid);
    Ok(())
}
