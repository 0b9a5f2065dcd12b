//! The inverse kinematics section: goals, their effector, depth, solver, limits and error.

use glam::Vec3;
use kloub_core::asset::NodeIndex;
use kloub_core::job::ik::{IkSolver, JointLimit};

use crate::control::Command;
use crate::model::Model;

use super::PanelActions;

/// Inverse kinematics: the goals (one target each), and for the selected one its effector,
/// depth, solver, iterations, limits and error.
pub(super) fn ik_panel(ui: &mut egui::Ui, model: &mut Model, actions: &mut PanelActions) {
    let mut on = !model.ik.is_empty();
    let toggled = ui
        .checkbox(&mut on, "Inverse kinematics")
        .on_hover_text(
            "Drag a ring in the viewport to move its target; click a joint to make it the selected goal's end effector",
        )
        .changed();
    if toggled {
        let command = match (on, model.ik_offers.first()) {
            (true, Some(&(effector, depth))) => Command::SetIk { effector: Some(effector), depth, target: None },
            _ => Command::SetIk { effector: None, depth: 0, target: None },
        };
        actions.commands.push(command);
    }
    if model.ik.is_empty() {
        return;
    }
    ui.horizontal_wrapped(|ui| {
        for (i, goal) in model.ik.iter().enumerate() {
            let text = format!("{} ({:.4})", model.node_name(goal.effector()), goal.report.error);
            if ui.selectable_label(i == model.ik_selected, text).clicked() {
                model.ik_selected = i;
            }
        }
    });
    ui.horizontal(|ui| {
        let unused = model.ik_offers.iter().find(|(j, _)| model.ik.iter().all(|g| g.effector() != *j));
        if ui
            .add_enabled(unused.is_some(), egui::Button::new("Add target"))
            .on_hover_text("Another end effector (the next hand or foot)")
            .clicked()
            && let Some(&(effector, depth)) = unused
        {
            actions.commands.push(Command::SetIk { effector: Some(effector), depth, target: None });
        }
        if model.ik.len() > 1 && ui.button("Remove").clicked() {
            actions.commands.push(Command::RemoveIk(model.ik_selected));
        }
    });
    let selected = model.ik_selected.min(model.ik.len() - 1);
    let ik = &model.ik[selected];
    let (effector, depth) = (ik.effector(), ik.depth());
    let mut chosen = effector;
    ui.horizontal(|ui| {
        let shown =
            egui::ComboBox::from_id_salt("effector").selected_text(model.node_name(effector)).show_ui(ui, |ui| {
                let joints = model.asset.skins.iter().flat_map(|s| s.joints.iter().copied());
                for joint in joints {
                    ui.selectable_value(&mut chosen, joint, model.node_name(joint));
                }
            });
        super::named_combo(&shown, "Effector");
        ui.label("effector");
    });
    let mut new_depth = depth;
    ui.add(egui::Slider::new(&mut new_depth, 1..=31).text("joints above"));
    if chosen != effector || new_depth != depth {
        let depth = if chosen != effector { depth.min(2) } else { new_depth };
        actions.commands.push(Command::ReplaceIk { goal: selected, effector: chosen, depth });
    }
    let ik = &mut model.ik[selected];
    let two_bone_ok = ik.depth() == 2;
    ui.horizontal(|ui| {
        let shown = egui::ComboBox::from_id_salt("solver").selected_text(solver_label(ik.solver)).show_ui(ui, |ui| {
            for solver in IkSolver::ALL {
                if solver == IkSolver::TwoBone && !two_bone_ok {
                    continue;
                }
                ui.selectable_value(&mut ik.solver, solver, solver_label(solver));
            }
        });
        super::named_combo(&shown, "Solver");
        ui.label("solver");
    });
    ui.add(egui::Slider::new(&mut ik.iterations, 1..=128).text("iterations"));
    if ik.solver == IkSolver::TwoBone {
        ui.add(egui::Slider::new(&mut ik.softness, 0.0..=0.5).text("soft reach")).on_hover_text(
            "The last part of the reach (a fraction of the chain's length) is approached smoothly,\nso the elbow or knee eases into full extension instead of snapping straight",
        );
        let mut pole = ik.pole.is_some();
        if ui
            .checkbox(&mut pole, "Pole")
            .on_hover_text("The middle joint bends towards the blue diamond: drag it in the viewport (the wheel over it moves it in depth)")
            .changed()
        {
            ik.pole = pole.then(|| ik.default_pole());
        }
    }
    if ik.solver == IkSolver::Ccd {
        ui.checkbox(&mut ik.accelerate, "Pattern move").on_hover_text(
            "After each CCD sweep, extrapolate the turn it made while the error keeps falling.\nOff: CCD exactly as the thesis has it (slow near full reach).",
        );
    }
    let kinds: Vec<&str> = ik
        .limits
        .iter()
        .map(|l| match l {
            JointLimit::Free => "free",
            JointLimit::Hinge { .. } => "hinge",
            JointLimit::Ball { .. } => "ball",
        })
        .collect();
    ui.checkbox(&mut ik.use_limits, "Joint limits").on_hover_text(format!(
        "Inferred from the joint names: elbows and knees are hinges, shoulders and hips ball joints.\nThis chain, root first: {}",
        kinds.join(", ")
    ));
    ui.add(egui::Slider::new(&mut ik.weight, 0.0..=1.0).text("weight"))
        .on_hover_text("How much of the solve is applied over the animated pose");
    chain_editor(ui, model, selected);
    let ik = &mut model.ik[selected];
    let reached = ik.report.error <= 1e-3;
    ui.label(format!(
        "error {:.5} after {} iteration{}{}",
        ik.report.error,
        ik.report.iterations,
        if ik.report.iterations == 1 { "" } else { "s" },
        if reached { " (reached)" } else { "" }
    ));
    ui.horizontal(|ui| {
        if ui.button("Target to effector").clicked()
            && let Some(p) = ik.joints.last()
        {
            ik.target = *p;
        }
        let save = ui.button("Save limits").on_hover_text(
            "Download <model>.kloub.json with the joint limits and stiffness that differ from the defaults; \
             drop it with the model (or onto it) to load it",
        );
        if save.clicked() {
            actions.save_sidecar = true;
        }
    });
}

/// The selected goal's chain, root first: each rotating joint's stiffness and limit (kind,
/// axis, angles in degrees), edited in the model's joint settings (saved by "Save limits").
pub(super) fn chain_editor(ui: &mut egui::Ui, model: &mut Model, goal: usize) {
    let Some(ik) = model.ik.get(goal) else { return };
    let joints: Vec<NodeIndex> = ik.chain.joints()[..ik.depth()].to_vec();
    let bones: Vec<Vec3> = ik.chain.joints()[1..]
        .iter()
        .map(|&c| model.asset.nodes.get(c as usize).map_or(Vec3::Y, |n| n.rest.translation))
        .collect();
    let mut changed = false;
    egui::CollapsingHeader::new("Chain joints: limits and stiffness").id_salt(("chain editor", goal)).show(ui, |ui| {
        for (i, &joint) in joints.iter().enumerate() {
            let j = joint as usize;
            let name = model.node_name(joint);
            let settings = &mut model.joint_settings;
            let (Some(limit), Some(stiffness)) = (settings.limits.get_mut(j), settings.stiffness.get_mut(j)) else {
                continue;
            };
            ui.separator();
            ui.strong(name);
            changed |= ui
                .add(egui::Slider::new(stiffness, 0.0..=1.0).text("stiffness η"))
                .on_hover_text("1 turns fully each sweep, 0 never moves")
                .changed();
            let kind = match limit {
                JointLimit::Free => 0,
                JointLimit::Hinge { .. } => 1,
                JointLimit::Ball { .. } => 2,
            };
            let mut new_kind = kind;
            ui.horizontal(|ui| {
                for (k, label) in ["free", "hinge", "ball"].into_iter().enumerate() {
                    ui.radio_value(&mut new_kind, k, label);
                }
            });
            if new_kind != kind {
                let bone = bones.get(i).copied().and_then(Vec3::try_normalize).unwrap_or(Vec3::Y);
                *limit = match new_kind {
                    1 => JointLimit::Hinge { axis: bone.any_orthonormal_vector(), min: 0.0, max: 150f32.to_radians() },
                    2 => JointLimit::Ball {
                        axis: bone,
                        swing: 60f32.to_radians(),
                        twist_min: (-45f32).to_radians(),
                        twist_max: 45f32.to_radians(),
                    },
                    _ => JointLimit::Free,
                };
                changed = true;
            }
            let degrees = |ui: &mut egui::Ui, value: &mut f32, range: std::ops::RangeInclusive<f32>, text: &str| {
                let mut d = value.to_degrees();
                let moved = ui.add(egui::Slider::new(&mut d, range).suffix("°").text(text)).changed();
                if moved {
                    *value = d.to_radians();
                }
                moved
            };
            match limit {
                JointLimit::Free => {}
                JointLimit::Hinge { axis, min, max } => {
                    ui.horizontal(|ui| {
                        ui.label("axis");
                        for (label, a) in [("x", Vec3::X), ("y", Vec3::Y), ("z", Vec3::Z)] {
                            if ui.selectable_label(axis.abs_diff_eq(a, 1e-4), label).clicked() {
                                *axis = a;
                                changed = true;
                            }
                        }
                        ui.weak(format!("({:.2}, {:.2}, {:.2})", axis.x, axis.y, axis.z));
                    });
                    changed |= degrees(ui, min, -180.0..=180.0, "min");
                    changed |= degrees(ui, max, -180.0..=180.0, "max");
                    if *min > *max {
                        std::mem::swap(min, max);
                    }
                }
                JointLimit::Ball { swing, twist_min, twist_max, .. } => {
                    changed |= degrees(ui, swing, 0.0..=180.0, "swing cone");
                    changed |= degrees(ui, twist_min, -180.0..=180.0, "twist min");
                    changed |= degrees(ui, twist_max, -180.0..=180.0, "twist max");
                    if *twist_min > *twist_max {
                        std::mem::swap(twist_min, twist_max);
                    }
                }
            }
        }
    });
    if changed {
        for ik in &mut model.ik {
            ik.use_settings(&model.joint_settings);
        }
    }
}

pub(super) fn solver_label(solver: IkSolver) -> &'static str {
    match solver {
        IkSolver::Ccd => "CCD",
        IkSolver::TwoBone => "Two-bone (analytic)",
        IkSolver::Fabrik => "FABRIK",
        IkSolver::Dls => "Damped least squares",
    }
}
