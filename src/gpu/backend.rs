//! The Vulkan kernels as a [`Backend`]: directions and parameter blocks in their std430 forms,
//! f32 results widened to f64.

use super::draws as counts;
use super::pipeline::Kernel;
use super::{CellCounting, Gpu, GpuDrawRequest, GpuPair, TableSwitches, DRAW_FLOATS};
use crate::backend::light::{SpherePixel, WeightedTexels};
use crate::backend::scene::Scene;
use crate::backend::{
    Backend, DrawCounting, DrawCounts, DrawRange, DrawRecord, NodeRule, Precision, Query, RowSums,
    TableSink,
};
use crate::interrupt::CancelToken;
use crate::model::{Brdf, Model, ParamSet};
use anyhow::Result;
use glam::DVec3;
use std::time::Duration;

/// A direction as the kernels read it: f32 xyz, padded to 16 bytes.
fn f32x4(v: DVec3) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, 0.0]
}

/// The std430 parameter block of each set.
fn blocks(sets: &[ParamSet]) -> Vec<Vec<u8>> {
    sets.iter().map(|p| Brdf::new(p).gpu_block()).collect()
}

/// The table kernel on the query's first set (none: nothing to do), `switches` but for the
/// white furnace taken from the query.
fn run_table(
    gpu: &Gpu,
    query: &Query,
    wi: &[DVec3],
    wo: &[DVec3],
    switches: TableSwitches,
    sink: &mut TableSink<'_>,
) -> Result<()> {
    let Some(params) = query.sets.first() else {
        return Ok(());
    };
    let wi: Vec<[f32; 4]> = wi.iter().map(|v| f32x4(*v)).collect();
    let wo: Vec<[f32; 4]> = wo.iter().map(|v| f32x4(*v)).collect();
    gpu.eval_table::<anyhow::Error>(
        params.model(),
        &Brdf::new(params).gpu_block(),
        &wi,
        &wo,
        TableSwitches {
            white_furnace: query.white_furnace,
            ..switches
        },
        sink,
    )
}

/// The kernel's model: the query's, which must be one.
fn one_model(query: &Query) -> Result<Option<Model>> {
    if !query.one_model() {
        anyhow::bail!("one GPU job evaluates parameter sets of one model (one kernel)");
    }
    Ok(query.model())
}

impl Backend for Gpu {
    fn name(&self) -> String {
        format!("gpu ({})", self.device().name())
    }

    fn device(&self) -> Option<String> {
        Some(self.device().name().to_string())
    }

    fn driver(&self) -> Option<String> {
        Some(self.device().driver().to_string())
    }

    fn precision(&self) -> Precision {
        Precision::F32
    }

    fn supports(&self, _model: Model) -> Result<()> {
        Ok(())
    }

    fn pairs(&self, query: Query, pairs: &[(DVec3, DVec3)]) -> Result<Vec<Vec<[f64; 3]>>> {
        let Some(model) = one_model(&query)? else {
            return Ok(Vec::new());
        };
        if pairs.is_empty() {
            return Ok(vec![Vec::new(); query.sets.len()]);
        }
        // Every set at every pair, in one list: each pair names its set's block.
        let gp: Vec<GpuPair> = (0..query.sets.len() as u32)
            .flat_map(|set| {
                pairs.iter().map(move |(wi, wo)| GpuPair {
                    wi: [wi.x as f32, wi.y as f32, wi.z as f32],
                    param_index: set,
                    wo: [wo.x as f32, wo.y as f32, wo.z as f32],
                    pad: 0,
                })
            })
            .collect();
        let out = self.eval_pairs(model, &blocks(query.sets), &gp, query.white_furnace)?;
        Ok(out
            .chunks(pairs.len())
            .map(|c| c.iter().map(|v| v.map(f64::from)).collect())
            .collect())
    }

    fn pdf(&self, query: Query, pairs: &[(DVec3, DVec3)]) -> Result<Vec<f64>> {
        let Some(params) = query.sets.first() else {
            return Ok(Vec::new());
        };
        let model = params.model();
        let gp: Vec<GpuPair> = pairs
            .iter()
            .map(|(wi, wo)| GpuPair {
                wi: [wi.x as f32, wi.y as f32, wi.z as f32],
                param_index: 0,
                wo: [wo.x as f32, wo.y as f32, wo.z as f32],
                pad: 0,
            })
            .collect();
        let block = blocks(&query.sets[..1]);
        let out = self.pdf_pairs(model, &block, &gp, query.white_furnace)?;
        Ok(out.into_iter().map(f64::from).collect())
    }

    fn draws(
        &self,
        query: Query,
        wo: DVec3,
        range: DrawRange,
        cancel: Option<&CancelToken>,
    ) -> Result<Vec<DrawRecord>> {
        let DrawRange {
            seed,
            group,
            first,
            count,
        } = range;
        let Some(params) = query.sets.first() else {
            return Ok(Vec::new());
        };
        let model = params.model();
        if model.spirv(Kernel::Sample.name()).is_none() {
            anyhow::bail!(
                "model {} has no sample kernel (a model defined at run time is given its \
                 kernels one by one); its draws run on the CPU backend",
                model.name()
            );
        }
        let request = GpuDrawRequest {
            wo: [wo.x as f32, wo.y as f32, wo.z as f32],
            seed,
            group,
            first_lo: first as u32,
            first_hi: (first >> 32) as u32,
            pad: 0,
        };
        let block = Brdf::new(params).gpu_block();
        let out = self.sample_draws(model, &block, request, count, query.white_furnace, cancel)?;
        Ok(out
            .chunks_exact(DRAW_FLOATS)
            .map(|d| {
                let v = |k: usize| f64::from(d[k]);
                DrawRecord {
                    wi: [v(0), v(1), v(2)],
                    pdf: v(3),
                    weight: [v(4), v(5), v(6)],
                    delta: d[7] != 0.0,
                    pdf_at: v(8),
                    eval_cos: [v(9), v(10), v(11)],
                }
            })
            .collect())
    }

    fn draw_counts(
        &self,
        query: Query,
        wo: DVec3,
        counting: DrawCounting,
        cancel: Option<&CancelToken>,
    ) -> Option<Result<DrawCounts>> {
        Some(self.count_draws(query, wo, counting, cancel))
    }

    fn table(
        &self,
        query: Query,
        wi: &[DVec3],
        wo: &[DVec3],
        fast_pow: bool,
        _cancel: Option<&CancelToken>,
        sink: &mut TableSink<'_>,
    ) -> Result<()> {
        let switches = TableSwitches {
            fast_pow,
            ..TableSwitches::default()
        };
        run_table(self, &query, wi, wo, switches, sink)
    }

    fn makes_upper_triangle(&self) -> bool {
        true
    }

    fn table_chunk_valid(&self) -> bool {
        super::table_chunk_valid()
    }

    /// The table kernel with UPPER_TRIANGLE.
    fn table_upper_triangle(
        &self,
        query: Query,
        wi: &[DVec3],
        wo: &[DVec3],
        fast_pow: bool,
        _cancel: Option<&CancelToken>,
        sink: &mut TableSink<'_>,
    ) -> Result<()> {
        let switches = TableSwitches {
            fast_pow,
            upper_triangle: true,
            ..TableSwitches::default()
        };
        run_table(self, &query, wi, wo, switches, sink)
    }

    fn rule_sums(
        &self,
        query: Query,
        rules: &[&dyn NodeRule],
        wo: &[DVec3],
        cancel: Option<&CancelToken>,
    ) -> Result<Vec<RowSums>> {
        let Some(model) = one_model(&query)? else {
            return Ok(vec![Vec::new(); rules.len()]);
        };
        let blocks = blocks(query.sets);
        super::sums::sum_rules(self, model, &blocks, query.white_furnace, rules, wo, cancel)
    }

    fn light(
        &self,
        query: Query,
        texels: &WeightedTexels,
        pixels: &[SpherePixel],
        cancel: Option<&CancelToken>,
    ) -> Result<Vec<[f64; 3]>> {
        let Some(params) = query.sets.first() else {
            return Ok(Vec::new());
        };
        let model = params.model();
        if model.spirv(Kernel::Light.name()).is_none() {
            anyhow::bail!(
                "model {} has no light kernel (a model defined at run time is given its kernels \
                 one by one); light it on the CPU backend",
                model.name()
            );
        }
        let block = Brdf::new(params).gpu_block();
        let out = self.light_pixels(model, &block, texels, pixels, query.white_furnace, cancel)?;
        Ok(out.iter().map(|v| v.map(f64::from)).collect())
    }

    fn preview(&self, query: Query, scene: &Scene) -> Result<Vec<[f32; 3]>> {
        let Some(model) = one_model(&query)? else {
            return Ok(Vec::new());
        };
        let cells = query.sets.len();
        let (header, lights) = super::preview::scene_header(scene, cells);
        let objects = super::preview::scene_objects(scene, cells);
        Ok(self.render_preview(model, &blocks(query.sets), &header, &lights, &objects)?)
    }

    fn take_device_time(&self) -> Option<Duration> {
        self.take_gpu_time()
    }

    fn built_kernels(&self) -> Vec<(String, Duration)> {
        self.built_pipelines()
    }
}

impl Gpu {
    /// [`Backend::draw_counts`] on the device: the counting kernel's chunks added up.
    fn count_draws(
        &self,
        query: Query,
        wo: DVec3,
        counting: DrawCounting,
        cancel: Option<&CancelToken>,
    ) -> Result<DrawCounts> {
        let DrawCounting {
            range,
            n_phi,
            n_cos,
            checked,
        } = counting;
        let cells = n_phi * n_cos;
        let Some(params) = query.sets.first() else {
            return Ok(DrawCounts {
                cells: vec![0; cells],
                ..DrawCounts::default()
            });
        };
        let model = params.model();
        if model.spirv(Kernel::Chi2.name()).is_none() {
            anyhow::bail!(
                "model {} has no counting kernel (a model defined at run time is given its \
                 kernels one by one); its sampling test runs on the CPU backend",
                model.name()
            );
        }
        let (Ok(np), Ok(nc)) = (u32::try_from(n_phi), u32::try_from(n_cos)) else {
            anyhow::bail!("{n_phi} × {n_cos} cells: too many for the counting kernel");
        };
        let request = GpuDrawRequest {
            wo: [wo.x as f32, wo.y as f32, wo.z as f32],
            seed: range.seed,
            group: range.group,
            first_lo: range.first as u32,
            first_hi: (range.first >> 32) as u32,
            pad: 0,
        };
        let block = Brdf::new(params).gpu_block();
        let mut words = vec![0u64; counts::COUNT_HEADER + cells];
        let cell_counting = CellCounting::for_device(self.device().cpu_kernels());
        self.chi2_counts(
            model,
            &block,
            request,
            [range.count as u64, checked],
            [np, nc],
            (query.white_furnace, cell_counting),
            cancel,
            &mut words,
        )?;
        let error = |k: usize| f64::from(f32::from_bits(words[k] as u32));
        Ok(DrawCounts {
            lost: words[counts::COUNT_LOST],
            delta: words[counts::COUNT_DELTA],
            invalid: words[counts::COUNT_INVALID],
            non_unit: words[counts::COUNT_NON_UNIT],
            zero_pdf: words[counts::COUNT_ZERO_PDF],
            non_finite_weight: words[counts::COUNT_NON_FINITE_WEIGHT],
            nonzero_weight_outside: words[counts::COUNT_WEIGHT_OUTSIDE],
            nonzero_pdf_below: words[counts::COUNT_PDF_BELOW],
            max_weight_error: error(counts::COUNT_WEIGHT_ERROR),
            max_pdf_error: error(counts::COUNT_PDF_ERROR),
            cells: words.split_off(counts::COUNT_HEADER),
        })
    }
}
