//! The pose section: "Animate | Pose", the selected joint's angles, posing within limits, and
//! the sculpt of a new example pose (brushes, radius, strength, Done).

use kloub_core::sculpt::Brush;

use crate::control::Command;
use crate::model::Model;

use super::PanelActions;

/// "Animate | Pose" and, in pose mode, what posing offers.
pub(super) fn pose_panel(ui: &mut egui::Ui, model: &Model, actions: &mut PanelActions) {
    super::radio_row(ui, "Mode", |ui| {
        if ui.selectable_label(!model.pose_mode, "Animate").on_hover_text("Play the clips").clicked() && model.pose_mode
        {
            actions.commands.push(Command::SetPoseMode(false));
        }
        if ui
            .selectable_label(model.pose_mode, "Pose")
            .on_hover_text("Stop the clip and pose joints: click one, turn it with the rings or the angles")
            .clicked()
            && !model.pose_mode
        {
            actions.commands.push(Command::SetPoseMode(true));
        }
    });
    if !model.pose_mode {
        return;
    }
    if let Some(state) = &model.sculpt {
        sculpt_panel(ui, model, state, actions);
        return;
    }
    let mut within = model.pose_within_limits;
    if ui
        .checkbox(&mut within, "Within limits")
        .on_hover_text("Keep each posed joint within its IK limit (the joint settings)")
        .changed()
    {
        actions.commands.push(Command::SetPoseWithinLimits(within));
    }
    let Some(joint) = model.selected_joint else {
        ui.weak("Click a joint on the model to pose it.");
        return;
    };
    ui.label(format!("Joint: {}", model.node_name(joint)));
    super::scene::pose_fields(ui, model, joint, actions);
    if ui
        .button("Add example pose")
        .on_hover_text(
            "Record this joint's rotation as an example pose of SJB by example and sculpt the shape it should have",
        )
        .clicked()
    {
        actions.commands.push(Command::AddExamplePose(joint));
    }
}

/// The sculpt of an example pose: the brush, its radius and strength, Done and Cancel.
fn sculpt_panel(ui: &mut egui::Ui, model: &Model, state: &crate::pose::SculptState, actions: &mut PanelActions) {
    let joint = model.node_name(state.sculpt.joint);
    ui.strong(format!("Sculpting an example pose of {joint}"));
    ui.weak("Drag over the highlighted vertices (the joint's support) to shape them; Shift-drag or the right button moves the camera.");
    let (mut brush, mut radius, mut strength) = (state.brush, state.radius, state.strength);
    let mut changed = false;
    super::radio_row(ui, "Brush", |ui| {
        for b in Brush::ALL {
            let label = match b {
                Brush::Inflate => "Inflate",
                Brush::Deflate => "Deflate",
                Brush::Smooth => "Smooth",
                Brush::Grab => "Grab",
            };
            changed |= ui.radio_value(&mut brush, b, label).changed();
        }
    });
    ui.horizontal(|ui| {
        let label = ui.label("Radius");
        changed |= ui
            .add(egui::Slider::new(&mut radius, 0.01..=0.3).max_decimals(3))
            .labelled_by(label.id)
            .on_hover_text("The brush's radius, as a fraction of the model's size")
            .changed();
    });
    ui.horizontal(|ui| {
        let label = ui.label("Strength");
        changed |= ui.add(egui::Slider::new(&mut strength, 0.0..=1.0).max_decimals(2)).labelled_by(label.id).changed();
    });
    if changed {
        actions.commands.push(Command::SetBrush { brush, radius, strength });
    }
    ui.label(format!("{} dabs", state.dabs));
    ui.horizontal(|ui| {
        if ui.button("Done").on_hover_text("Keep this shape as the example pose").clicked() {
            actions.commands.push(Command::FinishSculpt);
        }
        if ui.button("Cancel").on_hover_text("Drop this example pose").clicked() {
            actions.commands.push(Command::CancelSculpt);
        }
    });
}
