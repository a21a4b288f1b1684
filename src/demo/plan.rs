//! The plots the demo draws: which subjects, options and captions, decided before anything is
//! drawn (the page needs the captions and sizes; the albedo step's rows need the E(μ) curves).

use super::{Settings, PLOT_SIZE};
use crate::integrate::Method;
use crate::material;
use crate::model::Model;
use crate::plot::{self, PlotSettings, Request, Subject};
use anyhow::Result;

/// One plot the demo draws.
pub struct PlannedPlot {
    /// The picture's path, relative to the output folder.
    pub file: String,
    /// The caption the page shows under the picture.
    pub caption: String,
    /// The material all subjects share, if any (albedo curves per material).
    pub material: Option<&'static str>,
    /// The models drawn, with their parameters.
    pub subjects: Vec<Subject>,
    /// Settings every kind shares: size, scale and channel.
    pub common: PlotSettings,
    /// The kind of plot with its own options.
    pub request: Request,
}

/// The canvas of the demo's polar plots, in pixels.
const POLAR_SIZE: (u32, u32) = (1200, 680);

/// The demo's plots: polar overlays, a hemisphere map, and an E(μ) chart per material.
pub(super) fn plan_plots(
    settings: &Settings,
    materials: &[&'static str],
    models: &[Model],
) -> Result<Vec<PlannedPlot>> {
    let mut out = polar_plots(settings, materials)?;
    out.push(hemisphere_plot(settings)?);
    for &mat in materials {
        out.push(albedo_plot(settings, mat, models)?);
    }
    Ok(out)
}

/// A model at a material's preset, labelled with the material.
fn subject(mat: &str, model: Model) -> Result<Subject> {
    Ok(Subject::new(material::preset(mat, model)?, Some(mat)))
}

/// The canvas and scale of the line charts.
fn line_common() -> PlotSettings {
    PlotSettings {
        size: PLOT_SIZE,
        ..PlotSettings::default()
    }
}

/// Polar overlays: Cook–Torrance at every material, gold under the glossy models, and one lobe
/// at several incidence angles.
fn polar_plots(settings: &Settings, materials: &[&'static str]) -> Result<Vec<PlannedPlot>> {
    let line = line_common();
    // A half disc is twice as wide as tall: polar plots get a lower canvas.
    let log = PlotSettings {
        log: true,
        size: POLAR_SIZE,
        ..line.clone()
    };
    let polar = |theta: Vec<f64>| {
        Request::Polar(plot::polar::PolarOptions {
            theta_i_deg: theta,
            samples: settings.polar_samples,
            radius: plot::polar::Radius::Auto,
        })
    };
    Ok(vec![
        PlannedPlot {
            file: "plots/polar_cook_torrance_materials.png".into(),
            caption: "Cook–Torrance at the four materials, θi = 45°, log radius: roughness sets the lobe's width, the diffuse share its floor.".into(),
            material: None,
            subjects: materials
                .iter()
                .map(|m| subject(m, Model::CookTorrance))
                .collect::<Result<_>>()?,
            common: log.clone(),
            request: polar(vec![45.0]),
        },
        PlannedPlot {
            file: "plots/polar_gold_models.png".into(),
            caption: "Gold under the glossy models, θi = 45°, log radius; the coupled model's mirror spike is drawn as an arrow labelled with its albedo.".into(),
            material: None,
            subjects: [
                Model::Phong,
                Model::BlinnPhong,
                Model::CookTorrance,
                Model::AshikhminShirley,
                Model::Microfacet(crate::model::microfacet::MicrofacetConfig::DEFAULT),
                Model::Coupled,
            ]
            .into_iter()
            .map(|m| subject("gold", m))
            .collect::<Result<_>>()?,
            common: log.clone(),
            request: polar(vec![45.0]),
        },
        PlannedPlot {
            file: "plots/polar_glazed_ceramic_cook_torrance.png".into(),
            caption: "Glazed ceramic under Cook–Torrance at θi = 0°, 30°, 60°, 80°, linear radius: the lobe grows and tilts off-specular towards grazing.".into(),
            material: None,
            subjects: vec![subject("glazed_ceramic", Model::CookTorrance)?],
            common: PlotSettings {
                size: POLAR_SIZE,
                ..line.clone()
            },
            request: polar(vec![0.0, 30.0, 60.0, 80.0]),
        },
    ])
}

/// Hemisphere maps: an isotropic and an anisotropic lobe, four incidence angles each; the
/// height fits two rows of four square panels (as `lobe plot` sizes them).
fn hemisphere_plot(settings: &Settings) -> Result<PlannedPlot> {
    let hemi_subjects = vec![
        subject("gold", Model::CookTorrance)?,
        subject("tin", Model::AshikhminShirley)?,
    ];
    let side = 1090 / 4;
    Ok(PlannedPlot {
        file: "plots/hemisphere_gold_tin.png".into(),
        caption: "f over every ωo for ωi at θi = 0°, 30°, 60°, 80° (φi = 0), equal-area projection, log colour: gold Cook–Torrance (isotropic) and tin Ashikhmin–Shirley (anisotropic, brushed).".into(),
        material: None,
        common: PlotSettings {
            log: true,
            size: (1200, 150 + hemi_subjects.len() as u32 * (side + 30)),
            ..PlotSettings::default()
        },
        subjects: hemi_subjects,
        request: Request::Hemisphere(plot::hemisphere::HemisphereOptions {
            res: settings.hemisphere_res,
            ..Default::default()
        }),
    })
}

/// The E(μ) chart of every model at one material.
fn albedo_plot(settings: &Settings, mat: &'static str, models: &[Model]) -> Result<PlannedPlot> {
    Ok(PlannedPlot {
        file: format!("plots/albedo_{mat}.png"),
        caption: format!("Directional albedo E(μ) of every model at {mat}; above the dashed line E = 1 a model creates energy."),
        material: Some(mat),
        subjects: models
            .iter()
            .map(|&m| subject(mat, m))
            .collect::<Result<_>>()?,
        common: line_common(),
        request: Request::Albedo(plot::albedo_curve::AlbedoOptions {
            n_mu: settings.curve_mu,
            method: Method::Peak,
            samples: Some(settings.curve_samples),
            phi_deg: 0.0,
        }),
    })
}
