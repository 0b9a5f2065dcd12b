//! The candy-wrapper sample in the viewer: kloub_core's two-bone cylinder
//! ([`kloub_core::candy::CandyWrapper`]) with twist and bend sliders and a live quality
//! readout for every skinning method.

use kloub_core::Asset;
use kloub_core::Instance;
use kloub_core::candy::{CandyWrapper, Quality};
use kloub_core::job::dqs::SkinningMethod;
use kloub_core::pose::Pose;

use crate::load::LoadedModel;

/// The bend angles of the volume table (degrees).
pub const TABLE_BENDS: [f32; 6] = [0.0, 30.0, 60.0, 90.0, 120.0, 150.0];

/// The sample's panel state, owned by the model showing the rig.
#[derive(Clone)]
pub struct CandyPanel {
    /// The rig.
    pub rig: CandyWrapper,
    /// Twist of the joint about the bone axis, degrees.
    pub twist: f32,
    /// Bend of the joint about Z, degrees.
    pub bend: f32,
    /// The sliders pose the rig (instead of the playing clip).
    pub manual: bool,
    /// Quality of the current pose per method, in [`SkinningMethod::ALL`] order.
    pub quality: [Quality; SkinningMethod::ALL.len()],
    /// Volume ratio per bend of [`TABLE_BENDS`], per method.
    pub volume_table: [[f32; SkinningMethod::ALL.len()]; 6],
    measure: Instance,
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
}

impl CandyPanel {
    /// The rig at rest, with its volume table measured.
    pub fn new() -> Self {
        let rig = CandyWrapper::new();
        let mut measure = Instance::new(&rig.asset);
        // SJBBE measures with the rig's example pose (the shown model gets it from its sidecar).
        if let Err(e) = measure.set_examples(&rig.asset, rig.examples()) {
            log::warn!("candy wrapper: {e}");
        }
        let unit = Quality { radius_kept: 1.0, volume_ratio: 1.0 };
        let mut panel = Self {
            rig,
            twist: 150.0,
            bend: 0.0,
            manual: true,
            quality: [unit; SkinningMethod::ALL.len()],
            volume_table: [[1.0; SkinningMethod::ALL.len()]; 6],
            measure,
            positions: Vec::new(),
            normals: Vec::new(),
        };
        for (row, &bend) in TABLE_BENDS.iter().enumerate() {
            for (m, method) in SkinningMethod::ALL.into_iter().enumerate() {
                panel.volume_table[row][m] = panel.measure_pose(method, None, 0.0, bend).volume_ratio;
            }
        }
        panel
    }

    /// A loadable model of the rig.
    pub fn model(&self) -> LoadedModel {
        LoadedModel {
            name: "Candy wrapper".into(),
            asset: std::sync::Arc::new(self.rig.asset.clone()),
            warnings: Vec::new(),
            // The example pose of spherical joint blending by example.
            sidecar: Some(self.rig.example_sidecar()),
        }
    }

    /// Poses `instance` (of `asset`, the shown model's) by the sliders (when [`CandyPanel::manual`]).
    pub fn apply(&self, asset: &Asset, instance: &mut Instance) -> Result<(), String> {
        if self.manual {
            self.rig.pose_in(asset, instance, self.twist, self.bend).map_err(|e| e.to_string())?;
        }
        Ok(())
    }

    /// Measures every method on `pose` (the shown pose).
    pub fn update_quality(&mut self, pose: &Pose) {
        for (m, method) in SkinningMethod::ALL.into_iter().enumerate() {
            self.quality[m] = self.measure_pose(method, Some(pose), 0.0, 0.0);
        }
    }

    /// Quality of `method` on `pose`, or on the slider pose `twist`/`bend` without one.
    fn measure_pose(&mut self, method: SkinningMethod, pose: Option<&Pose>, twist: f32, bend: f32) -> Quality {
        let asset = &self.rig.asset;
        self.measure.set_skinning(asset, method);
        let posed = match pose {
            // The shown pose's joints (its weights are the example targets' of the shown model).
            Some(pose) => {
                self.measure.pose_mut().locals.clone_from(&pose.locals);
                self.measure.update(asset).map_err(|e| e.to_string())
            }
            None => self.rig.pose(&mut self.measure, twist, bend).map_err(|e| e.to_string()),
        };
        let deformed = posed.and_then(|()| {
            self.measure
                .deform_primitive(asset, 2, 0, &mut self.positions, &mut self.normals)
                .map_err(|e| e.to_string())
        });
        match deformed {
            Ok(()) => self.rig.quality(&self.positions),
            Err(e) => {
                log::warn!("candy wrapper: {e}");
                Quality { radius_kept: f32::NAN, volume_ratio: f32::NAN }
            }
        }
    }
}

impl Default for CandyPanel {
    fn default() -> Self {
        Self::new()
    }
}

/// The built-in samples of the Samples menu.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sample {
    /// The candy-wrapper skinning rig.
    CandyWrapper,
}

impl Sample {
    /// Every sample, in menu order.
    pub const ALL: [Sample; 1] = [Sample::CandyWrapper];

    /// The name the page uses (`loadSample("candy-wrapper")`).
    pub fn name(self) -> &'static str {
        match self {
            Sample::CandyWrapper => "candy-wrapper",
        }
    }

    /// The menu label.
    pub fn label(self) -> &'static str {
        match self {
            Sample::CandyWrapper => "Candy wrapper (skinning rig)",
        }
    }

    /// The sample named `name`.
    pub fn from_name(name: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|s| s.name() == name).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(|s| s.name()).collect();
            format!("no sample named {name:?}; samples: {}", names.join(", "))
        })
    }
}
