//! Per-joint IK settings of a model — limits and stiffness — with humanoid defaults and the
//! `<model>.kloub.json` sidecar that edits them:
//!
//! ```json
//! { "ik": {
//!     "limits": {
//!       "arm_joint_L_2": { "hinge": { "axis": [1, 0, 0], "min": -10, "max": 150 } },
//!       "arm_joint_L_1": { "ball": { "axis": [0, 1, 0], "swing": 90, "twist": [-45, 45] } },
//!       "neck_joint_1": "free" },
//!     "stiffness": { "torso_joint_2": 0.3 } } }
//! ```
//! Angles are in degrees, axes in the joint's rest frame; joints are named as in the file.
//! Joints the sidecar does not name keep their defaults ([`humanoid_limits`], stiffness 1).

use serde_json::{Map, Value, json};

use crate::asset::Asset;
use crate::job::ik::{IkChain, JointLimit, humanoid_limits};
use crate::math::Vec3;

/// Limits and stiffness of every node of one asset.
#[derive(Clone, Debug, PartialEq)]
pub struct JointSettings {
    /// Limit per node.
    pub limits: Vec<JointLimit>,
    /// CCD/DLS stiffness per node, in `[0, 1]`.
    pub stiffness: Vec<f32>,
}

impl JointSettings {
    /// Humanoid defaults inferred from the joint names, stiffness 1.
    pub fn humanoid(asset: &Asset) -> Self {
        Self { limits: humanoid_limits(asset), stiffness: vec![1.0; asset.nodes.len()] }
    }

    /// Limits and stiffness of `chain`'s rotating joints, root first (nodes outside these
    /// settings are free with stiffness 1).
    pub fn chain(&self, chain: &IkChain) -> (Vec<JointLimit>, Vec<f32>) {
        let rotating = &chain.joints()[..chain.depth()];
        let limits = rotating.iter().map(|&j| self.limits.get(j as usize).copied().unwrap_or_default()).collect();
        let stiffness = rotating.iter().map(|&j| self.stiffness.get(j as usize).copied().unwrap_or(1.0)).collect();
        (limits, stiffness)
    }

    /// Applies a sidecar (see the module docs) on top of these settings. Nothing changes on
    /// error.
    ///
    /// # Errors
    /// Malformed JSON, an unknown joint, or a bad value, naming its JSON pointer
    /// (`/ik/limits/arm_joint_L_2/hinge/min: ...`).
    pub fn apply_json(&mut self, asset: &Asset, json: &str) -> Result<(), String> {
        let root: Value = serde_json::from_str(json).map_err(|e| format!("not JSON: {e}"))?;
        let mut next = self.clone();
        let Some(ik) = root.get("ik") else { return Ok(()) };
        let ik = ik.as_object().ok_or("/ik: expected an object")?;
        let node = |name: &str, pointer: &str| {
            asset
                .nodes
                .iter()
                .position(|n| n.name.as_deref() == Some(name))
                .ok_or_else(|| format!("{pointer}: no joint named {name:?} in the model"))
        };
        if let Some(limits) = ik.get("limits") {
            let limits = limits.as_object().ok_or("/ik/limits: expected an object")?;
            for (name, value) in limits {
                let pointer = format!("/ik/limits/{}", escape(name));
                let index = node(name, &pointer)?;
                next.limits[index] = parse_limit(value, &pointer)?;
            }
        }
        if let Some(stiffness) = ik.get("stiffness") {
            let stiffness = stiffness.as_object().ok_or("/ik/stiffness: expected an object")?;
            for (name, value) in stiffness {
                let pointer = format!("/ik/stiffness/{}", escape(name));
                let index = node(name, &pointer)?;
                let eta = value
                    .as_f64()
                    .map(|v| v as f32)
                    .filter(|v| v.is_finite() && (0.0..=1.0).contains(v))
                    .ok_or_else(|| format!("{pointer}: expected a number in [0, 1]"))?;
                next.stiffness[index] = eta;
            }
        }
        *self = next;
        Ok(())
    }

    /// The sidecar that reproduces these settings: every named node whose limit or stiffness
    /// differs from `defaults`.
    pub fn to_json(&self, asset: &Asset, defaults: &JointSettings) -> String {
        let mut limits = Map::new();
        let mut stiffness = Map::new();
        for (i, node) in asset.nodes.iter().enumerate() {
            let Some(name) = node.name.as_deref() else { continue };
            if self.limits.get(i) != defaults.limits.get(i)
                && let Some(limit) = self.limits.get(i)
            {
                limits.insert(name.to_owned(), limit_json(limit));
            }
            if let (Some(&eta), Some(&default)) = (self.stiffness.get(i), defaults.stiffness.get(i))
                && eta != default
            {
                stiffness.insert(name.to_owned(), json!(eta));
            }
        }
        let doc = json!({ "ik": { "limits": limits, "stiffness": stiffness } });
        serde_json::to_string_pretty(&doc).unwrap_or_default()
    }
}

/// A JSON pointer token (`~` → `~0`, `/` → `~1`).
pub fn escape(name: &str) -> String {
    name.replace('~', "~0").replace('/', "~1")
}

fn degrees(value: Option<&Value>, pointer: &str) -> Result<f32, String> {
    value
        .and_then(Value::as_f64)
        .map(|d| (d as f32).to_radians())
        .filter(|r| r.is_finite() && r.abs() <= std::f32::consts::PI + 1e-4)
        .ok_or_else(|| format!("{pointer}: expected an angle in degrees within ±180"))
}

fn axis(value: Option<&Value>, pointer: &str) -> Result<Vec3, String> {
    let parts: Option<Vec<f32>> =
        value.and_then(Value::as_array).map(|a| a.iter().filter_map(|v| v.as_f64().map(|f| f as f32)).collect());
    match parts.as_deref() {
        Some(&[x, y, z]) => {
            Vec3::new(x, y, z).try_normalize().ok_or_else(|| format!("{pointer}: the axis is zero or not finite"))
        }
        _ => Err(format!("{pointer}: expected [x, y, z]")),
    }
}

fn parse_limit(value: &Value, pointer: &str) -> Result<JointLimit, String> {
    if value.as_str() == Some("free") {
        return Ok(JointLimit::Free);
    }
    let object = value
        .as_object()
        .ok_or_else(|| format!("{pointer}: expected \"free\", {{\"hinge\": ...}} or {{\"ball\": ...}}"))?;
    match (object.get("hinge"), object.get("ball")) {
        (Some(h), None) => {
            let p = format!("{pointer}/hinge");
            let (min, max) = (degrees(h.get("min"), &format!("{p}/min"))?, degrees(h.get("max"), &format!("{p}/max"))?);
            if min > max {
                return Err(format!("{p}: min is above max"));
            }
            Ok(JointLimit::Hinge { axis: axis(h.get("axis"), &format!("{p}/axis"))?, min, max })
        }
        (None, Some(b)) => {
            let p = format!("{pointer}/ball");
            let swing = degrees(b.get("swing"), &format!("{p}/swing"))?;
            let twist = b.get("twist").and_then(Value::as_array);
            let (twist_min, twist_max) = match twist.map(Vec::as_slice) {
                Some([lo, hi]) => {
                    (degrees(Some(lo), &format!("{p}/twist/0"))?, degrees(Some(hi), &format!("{p}/twist/1"))?)
                }
                _ => return Err(format!("{p}/twist: expected [min, max] in degrees")),
            };
            if swing < 0.0 || twist_min > twist_max {
                return Err(format!("{p}: swing must be ≥ 0 and twist min ≤ max"));
            }
            Ok(JointLimit::Ball { axis: axis(b.get("axis"), &format!("{p}/axis"))?, swing, twist_min, twist_max })
        }
        _ => Err(format!("{pointer}: expected exactly one of \"hinge\" and \"ball\"")),
    }
}

fn limit_json(limit: &JointLimit) -> Value {
    let deg = |r: f32| f64::from(r.to_degrees());
    match *limit {
        JointLimit::Free => json!("free"),
        JointLimit::Hinge { axis, min, max } => {
            json!({ "hinge": { "axis": axis.to_array(), "min": deg(min), "max": deg(max) } })
        }
        JointLimit::Ball { axis, swing, twist_min, twist_max } => {
            json!({ "ball": { "axis": axis.to_array(), "swing": deg(swing), "twist": [deg(twist_min), deg(twist_max)] } })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sidecar_overrides_the_defaults_and_round_trips() {
        let asset = crate::testutil::load("khronos/RiggedFigure/glTF-Binary/RiggedFigure.glb");
        let defaults = JointSettings::humanoid(&asset);
        let mut settings = defaults.clone();
        let sidecar = r#"{ "ik": {
            "limits": {
                "arm_joint_L_2": { "hinge": { "axis": [0, 0, 2], "min": -10, "max": 150 } },
                "arm_joint_L_1": { "ball": { "axis": [0, 1, 0], "swing": 90, "twist": [-45, 45] } },
                "leg_joint_L_2": "free" },
            "stiffness": { "torso_joint_2": 0.3 } } }"#;
        settings.apply_json(&asset, sidecar).expect("valid sidecar");
        let find = |name: &str| asset.nodes.iter().position(|n| n.name.as_deref() == Some(name)).expect("joint");
        match settings.limits[find("arm_joint_L_2")] {
            JointLimit::Hinge { axis, min, max } => {
                assert!(axis.abs_diff_eq(Vec3::Z, 1e-6));
                assert!((min + 10f32.to_radians()).abs() < 1e-6 && (max - 150f32.to_radians()).abs() < 1e-6);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(settings.limits[find("leg_joint_L_2")], JointLimit::Free);
        assert_eq!(settings.stiffness[find("torso_joint_2")], 0.3);
        // Untouched joints keep their defaults; the sidecar written back reads back the same.
        assert_eq!(settings.limits[find("arm_joint_R_2")], defaults.limits[find("arm_joint_R_2")]);
        let written = settings.to_json(&asset, &defaults);
        let mut again = defaults.clone();
        again.apply_json(&asset, &written).expect("its own output");
        for (a, b) in again.limits.iter().zip(&settings.limits) {
            match (a, b) {
                (JointLimit::Hinge { min: a, max: b, .. }, JointLimit::Hinge { min: c, max: d, .. }) => {
                    assert!((a - c).abs() < 1e-5 && (b - d).abs() < 1e-5);
                }
                (a, b) => assert_eq!(std::mem::discriminant(a), std::mem::discriminant(b)),
            }
        }
        assert_eq!(again.stiffness, settings.stiffness);
    }

    #[test]
    fn a_bad_sidecar_names_the_pointer_and_changes_nothing() {
        let asset = crate::testutil::load("khronos/RiggedFigure/glTF-Binary/RiggedFigure.glb");
        let defaults = JointSettings::humanoid(&asset);
        for (json, pointer) in [
            (r#"{"ik": {"limits": {"nope": "free"}}}"#, "/ik/limits/nope"),
            (
                r#"{"ik": {"limits": {"arm_joint_L_2": {"hinge": {"axis": [0,0,0], "min": 0, "max": 1}}}}}"#,
                "/ik/limits/arm_joint_L_2/hinge/axis",
            ),
            (
                r#"{"ik": {"limits": {"arm_joint_L_2": {"hinge": {"axis": [1,0,0], "min": 10, "max": 1}}}}}"#,
                "/ik/limits/arm_joint_L_2/hinge",
            ),
            (
                r#"{"ik": {"limits": {"arm_joint_L_1": {"ball": {"axis": [0,1,0], "swing": 500, "twist": [0, 1]}}}}}"#,
                "/ik/limits/arm_joint_L_1/ball/swing",
            ),
            (r#"{"ik": {"stiffness": {"torso_joint_2": 2}}}"#, "/ik/stiffness/torso_joint_2"),
            (r#"{"ik": []}"#, "/ik"),
        ] {
            let mut settings = defaults.clone();
            let err = settings.apply_json(&asset, json).expect_err(json);
            assert!(err.starts_with(pointer), "{err:?} should name {pointer}");
            assert_eq!(settings, defaults, "a failed sidecar changed the settings");
        }
        assert!(defaults.clone().apply_json(&asset, "{").is_err());
        let mut unchanged = defaults.clone();
        unchanged.apply_json(&asset, "{}").expect("nothing to apply");
        assert_eq!(unchanged, defaults);
    }
}
