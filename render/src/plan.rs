//! The pipeline a render builds, decided before any device call: which features it compiles,
//! which programs, with which compile options. The renderer builds exactly this plan and
//! `optik render --features` prints it, so the printout cannot drift from what runs.

use crate::features::RenderFeatures;
use crate::scene::Scene;
use optik::{FeatureSet, PipelineCompileOptions, Setting, TraversableGraph};

/// Which effects a pipeline compiles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Effects {
    /// Only what the scene calls for ([`RenderFeatures::of`]), traversal features left to
    /// optik's `Auto` specialisation: the renderer's normal pipeline.
    #[default]
    Scene,
    /// Every effect the renderer has ([`RenderFeatures::with_every_effect`]) and every traversal
    /// feature: the unspecialised pipeline the benchmark mode compares against.
    All,
}

impl Effects {
    /// `specialised` or `all-effects`, as reports name the pipelines.
    pub fn name(self) -> &'static str {
        match self {
            Effects::Scene => "specialised",
            Effects::All => "all-effects",
        }
    }
}

/// The pipeline for one scene: the features compiled, the programs in program group order,
/// and the compile options.
#[derive(Clone, Debug, PartialEq)]
pub struct PipelinePlan {
    /// Which pipeline this is.
    pub effects: Effects,
    /// What the scene itself calls for.
    pub scene_features: RenderFeatures,
    /// What is compiled: the scene's features, or every effect.
    pub features: RenderFeatures,
    /// Program names in program group order ([`RenderFeatures::programs`]).
    pub programs: Vec<String>,
    /// The pipeline (and module) compile options.
    pub compile_options: PipelineCompileOptions,
}

impl PipelinePlan {
    /// The plan for `scene`; `aovs` adds the first hit's albedo and normal to the payload.
    pub fn new(scene: &Scene, aovs: bool, effects: Effects) -> PipelinePlan {
        let scene_features = RenderFeatures::of(scene, aovs);
        let features = match effects {
            Effects::Scene => scene_features.clone(),
            Effects::All => scene_features.with_every_effect(),
        };
        let compile_options = match effects {
            Effects::Scene => PipelineCompileOptions {
                num_payload_values: Setting::Value(features.payload_values),
                ..Default::default()
            },
            Effects::All => {
                let every = FeatureSet::everything(1);
                PipelineCompileOptions {
                    num_payload_values: Setting::Value(features.payload_values),
                    uses_motion_blur: Setting::Value(true),
                    traversable_graph: Setting::Value(TraversableGraph::Any),
                    primitive_types: Setting::Value(every.primitive_types),
                    ..Default::default()
                }
            }
        };
        PipelinePlan {
            effects,
            programs: features.programs(),
            scene_features,
            features,
            compile_options,
        }
    }

    /// What `--features` prints: the scene's features, then what this pipeline compiles (the
    /// features, when they differ from the scene's; the programs; the compile options, `auto`
    /// where optik specialises from the acceleration structures and programs).
    pub fn describe(&self) -> String {
        let mut s = String::from("scene features:\n");
        s += &indent(&self.scene_features.describe());
        s += &format!("pipeline: {}\n", self.effects.name());
        if self.features != self.scene_features {
            s += "compiled features:\n";
            s += &indent(&self.features.describe());
        }
        s += &format!("programs: {}\n", self.programs.join(", "));
        let o = &self.compile_options;
        s += "compile options:\n";
        s += &format!("  payload registers: {}\n", setting(o.num_payload_values));
        s += &format!(
            "  primitive types: {}\n",
            match o.primitive_types {
                Setting::Auto => "auto".to_string(),
                Setting::Value(p) => p.names().join(" "),
            }
        );
        s += &format!(
            "  traversable graph: {}\n",
            match o.traversable_graph {
                Setting::Auto => "auto".to_string(),
                Setting::Value(g) => graph_name(g).to_string(),
            }
        );
        s += &format!("  motion blur: {}\n", setting(o.uses_motion_blur));
        s
    }
}

/// The traversal features a device compiled (`pipeline_features`), one line for `--features`.
pub fn describe_compiled(f: &FeatureSet) -> String {
    format!(
        "{} ({} payload registers)",
        f.names().join(" "),
        f.num_payload_values
    )
}

fn setting<T: std::fmt::Display + Copy>(s: Setting<T>) -> String {
    match s {
        Setting::Auto => "auto".into(),
        Setting::Value(v) => v.to_string(),
    }
}

fn indent(text: &str) -> String {
    text.lines().map(|l| format!("  {l}\n")).collect()
}

fn graph_name(g: TraversableGraph) -> &'static str {
    match g {
        TraversableGraph::SingleGas => "single-gas",
        TraversableGraph::SingleLevelInstancing => "single-level-instancing",
        TraversableGraph::Any => "any-graph",
    }
}
