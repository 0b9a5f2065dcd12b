//! The skinning section: method and path, the deviation heatmap, SJB's fallbacks, and the candy
//! wrapper's sample.

use kloub_core::job::dqs::SkinningMethod;

use crate::candy::{CandyPanel, TABLE_BENDS};
use crate::control::Command;
use crate::render::SkinningPath;

use super::{PanelActions, PanelState};

/// Skinning method and path, and SJB's fallback count.
pub(super) fn skinning_panel(ui: &mut egui::Ui, state: &PanelState<'_>, actions: &mut PanelActions) {
    ui.strong("Skinning");
    let shown =
        egui::ComboBox::from_id_salt("skinning method").selected_text(method_label(state.skinning)).show_ui(ui, |ui| {
            for method in SkinningMethod::ALL {
                let response = ui.selectable_label(state.skinning == method, method_label(method));
                if response.on_hover_text(method_hint(method)).clicked() && state.skinning != method {
                    actions.commands.push(Command::SetSkinning(method));
                }
            }
        });
    super::named_combo(&shown, "Skinning method");
    super::radio_row(ui, "Skinning path", |ui| {
        for path in SkinningPath::ALL.into_iter().filter(|&p| p != SkinningPath::Compute || state.compute) {
            // A click on the path in use makes it the chosen one (it may be the default's or the heatmap's).
            if ui.radio(state.skinning_path == path, path.label()).clicked()
                && (state.skinning_path != path || !state.skinning_path_chosen)
            {
                actions.commands.push(Command::SetSkinningPath(path));
            }
        }
    });
    let mut heatmap = state.heatmap;
    let reference = if state.skinning == SkinningMethod::Linear { "DQS" } else { "LBS" };
    let toggle = ui
        // The vertex shader draws it: the path chosen, or no path chosen (the heatmap then takes the viewer there).
        .add_enabled(
            !state.skinning_path_chosen || state.skinning_path == SkinningPath::Gpu,
            egui::Checkbox::new(&mut heatmap, "Deviation heatmap"),
        )
        .on_hover_text(format!(
            "Colours each vertex by its distance from {reference}'s result: blue none, red 2% of the model's size \
             (vertex-shader path)"
        ));
    if toggle.changed() {
        actions.commands.push(Command::SetHeatmap(heatmap));
    }
    if state.skinning.uses_sjb_plan() {
        let (vertices, fallbacks) =
            state.sjb_fallbacks.iter().fold((0, 0), |(v, f), &(_, vertices, fallbacks)| (v + vertices, f + fallbacks));
        ui.label(format!("{fallbacks} of {vertices} vertices share no joint centre and use DQS"))
            .on_hover_text(sjb_breakdown(state.sjb_fallbacks));
    }
}

pub(super) fn method_label(method: SkinningMethod) -> &'static str {
    match method {
        SkinningMethod::Rigid => "Rigid (strongest joint)",
        SkinningMethod::Linear => "Linear blend (LBS)",
        SkinningMethod::DualQuaternion => "Dual quaternion (DQS)",
        SkinningMethod::SphericalJointBlend => "Spherical joint blend (SJB)",
        SkinningMethod::SphericalJointBlendByExample => "SJB by example (SJBBE)",
    }
}

pub(super) fn method_hint(method: SkinningMethod) -> &'static str {
    match method {
        SkinningMethod::Rigid => "Each vertex follows its strongest joint only: rigid parts, cracks at joints",
        SkinningMethod::Linear => {
            "Blends the joint matrices: the glTF reference; collapses under twist, loses volume when bent"
        }
        SkinningMethod::DualQuaternion => {
            "Blends rigid transforms as dual quaternions: keeps volume under twist and bend"
        }
        SkinningMethod::SphericalJointBlend => {
            "Rotates vertices about their shared joint centre (Hejl); vertices whose joints share no centre use DQS"
        }
        SkinningMethod::SphericalJointBlendByExample => {
            "SJB after the example poses' shapes, weighted by how close each joint is to its examples (Houska)"
        }
    }
}

pub(super) fn sjb_breakdown(draws: &[(usize, usize, usize)]) -> String {
    let lines: Vec<String> =
        draws.iter().map(|(mesh, vertices, fallbacks)| format!("mesh {mesh}: {fallbacks} of {vertices}")).collect();
    lines.join("\n")
}

/// The candy-wrapper sample: twist and bend sliders, quality per method, the volume table.
pub(super) fn candy_panel(ui: &mut egui::Ui, candy: &CandyPanel, current: SkinningMethod, actions: &mut PanelActions) {
    ui.strong("Candy wrapper");
    let (mut twist, mut bend) = (candy.twist, candy.bend);
    let twisted = ui.add(egui::Slider::new(&mut twist, -180.0..=180.0).suffix("°").text("twist")).changed();
    let bent = ui.add(egui::Slider::new(&mut bend, 0.0..=150.0).suffix("°").text("bend")).changed();
    if twisted || bent || (!candy.manual && ui.button("Pose by sliders").clicked()) {
        actions.commands.push(Command::SetCandyPose { twist, bend });
    }
    if !candy.manual {
        ui.weak("A clip poses the rig; move a slider to take over.");
    }
    egui::Grid::new("candy quality").striped(true).show(ui, |ui| {
        ui.label("method");
        ui.label("radius at joint")
            .on_hover_text("Mean distance of the joint's cross-section from its centre, over the rest radius");
        ui.label("volume").on_hover_text("Enclosed volume over the rest volume");
        ui.end_row();
        for (method, q) in SkinningMethod::ALL.into_iter().zip(&candy.quality) {
            let name = method.name().to_uppercase();
            if method == current {
                ui.strong(name)
            } else {
                ui.label(name)
            };
            ui.label(format!("{:.0}%", q.radius_kept * 100.0));
            ui.label(format!("{:.1}%", q.volume_ratio * 100.0));
            ui.end_row();
        }
    });
    egui::CollapsingHeader::new("Volume under bend").id_salt("candy volume table").show(ui, |ui| {
        egui::Grid::new("candy volume").striped(true).show(ui, |ui| {
            ui.label("bend");
            for method in SkinningMethod::ALL {
                ui.label(method.name().to_uppercase());
            }
            ui.end_row();
            for (bend, row) in TABLE_BENDS.iter().zip(&candy.volume_table) {
                ui.label(format!("{bend:.0}°"));
                for v in row {
                    ui.label(format!("{:.1}%", v * 100.0));
                }
                ui.end_row();
            }
        });
    });
}

/// The example poses of SJB by example and their weights α now (seed 001 §5.3: 1 at an
/// example, 0 at the rest pose, interpolated between by radial basis functions).
pub(super) fn examples_panel(
    ui: &mut egui::Ui,
    model: &crate::model::Model,
    skinning: SkinningMethod,
    actions: &mut PanelActions,
) {
    let Some((examples, targets)) = &model.examples else { return };
    let current = targets.current(&model.instance);
    ui.label(format!("Example poses ({})", examples.poses.len())).on_hover_text(
        "From the sidecar: under SJBBE each example's shape is blended in by how close its joint is to the example \
         (α: 1 at the example, 0 at rest)",
    );
    if skinning != SkinningMethod::SphericalJointBlendByExample {
        ui.weak("Choose SJB by example to apply them.");
    }
    // σ per joint: how far from its examples a pose still takes part of them.
    let mut joints: Vec<u32> = examples.poses.iter().map(|p| p.node).collect();
    joints.dedup();
    for node in joints {
        let mut sigma =
            examples.sigma.iter().find(|(n, _)| *n == node).map_or(kloub_core::job::sjbbe::DEFAULT_SIGMA, |s| s.1);
        let name = format!("σ {}", model.node_name(node));
        ui.horizontal(|ui| {
            let label = ui.label(&name);
            let response = ui
                .add(egui::Slider::new(&mut sigma, 0.1..=3.0).suffix(" rad").max_decimals(2))
                .labelled_by(label.id)
                .on_hover_text("The Gaussians' width over the arc between bone directions (the seed's is 1)");
            if response.drag_stopped() || (response.changed() && !response.dragged()) {
                actions.commands.push(Command::SetExampleSigma { node, sigma });
            }
        });
    }
    egui::Grid::new("sjbbe examples").striped(true).show(ui, |ui| {
        for (skin, joint, example, alpha) in current {
            let node = model.asset.skins.get(skin).and_then(|s| s.joints.get(usize::from(joint))).copied();
            let name = node.map_or_else(|| format!("joint {joint}"), |n| model.node_name(n));
            ui.label(&name);
            ui.label(format!("#{}", example + 1));
            ui.label(format!("α {alpha:.2}"));
            // The example's place in the sidecar's list: the joint's `example`-th.
            let index =
                (examples.poses.iter().enumerate()).filter(|(_, p)| Some(p.node) == node).nth(example).map(|(i, _)| i);
            if let (Some(index), Some(node)) = (index, node) {
                // Select: the joint posed at the example's rotation (α 1 there), in pose mode.
                let show = ui.small_button("Pose").on_hover_text(format!("Pose {name} as in example #{}", example + 1));
                show.widget_info(|| {
                    egui::WidgetInfo::labeled(
                        egui::Role::Button,
                        true,
                        format!("Pose example {} of {name}", example + 1),
                    )
                });
                if show.clicked()
                    && let Some(e) = examples.poses.get(index)
                {
                    actions.commands.push(Command::SetPoseMode(true));
                    actions.commands.push(Command::SelectJoint(Some(node)));
                    actions.commands.push(Command::SetJointRotation { node, rotation: Some(e.rotation.to_array()) });
                }
                let delete = ui
                    .add_enabled(model.sculpt.is_none(), egui::Button::new("Delete").small())
                    .on_hover_text(format!("Delete example #{} of {name}", example + 1));
                delete.widget_info(|| {
                    egui::WidgetInfo::labeled(
                        egui::Role::Button,
                        true,
                        format!("Delete example {} of {name}", example + 1),
                    )
                });
                if delete.clicked() {
                    actions.commands.push(Command::DeleteExample(index));
                }
            }
            ui.end_row();
        }
    });
    if ui
        .button("Save examples")
        .on_hover_text(
            "Download <model>.kloub.json with the example poses and joint settings (drop it back to restore them)",
        )
        .clicked()
    {
        actions.save_sidecar = true;
    }
}
