//! The Validation section: runs the Khronos glTF-Validator on the shown model (through the
//! element) and lists its report: a badge with the counts, then each issue with its code and
//! JSON pointer.

use super::PanelActions;
use crate::model::Model;

/// Colours of the severities (readable on both themes' panels).
fn colour(severity: u8) -> egui::Color32 {
    match severity {
        0 => egui::Color32::from_rgb(0xe0, 0x4f, 0x4f),
        1 => egui::Color32::from_rgb(0xd8, 0x9a, 0x2b),
        2 => egui::Color32::from_rgb(0x4f, 0x9a, 0xe0),
        _ => egui::Color32::GRAY,
    }
}

/// The "Validate" button, the badge and the issue list.
pub(super) fn validation_panel(ui: &mut egui::Ui, model: &Model, actions: &mut PanelActions) {
    ui.horizontal(|ui| {
        let button = ui
            .add_enabled(!model.validating, egui::Button::new("Validate"))
            .on_hover_text("Check the file with the Khronos glTF-Validator (downloaded on first use)");
        if button.clicked() {
            actions.validate = true;
        }
        if model.validating {
            ui.spinner();
        }
        let Some(validation) = &model.validation else { return };
        match &validation.outcome {
            Ok(report) => {
                let plural = |n: u32, one: &str| if n == 1 { format!("1 {one}") } else { format!("{n} {one}s") };
                let badge = format!(
                    "{} · {} · {} · {}",
                    plural(report.errors, "error"),
                    plural(report.warnings, "warning"),
                    plural(report.infos, "info"),
                    plural(report.hints, "hint")
                );
                let tone = match (report.errors, report.warnings) {
                    (0, 0) => egui::Color32::from_rgb(0x3f, 0xa8, 0x5a),
                    (0, _) => colour(1),
                    _ => colour(0),
                };
                ui.label(egui::RichText::new(badge).color(tone).strong())
                    .on_hover_text(format!("glTF-Validator {}", report.validator));
            }
            Err(message) => {
                ui.label(egui::RichText::new(message).color(colour(0)));
            }
        }
    });
    let Some(Ok(report)) = model.validation.as_ref().map(|v| &v.outcome) else { return };
    if report.issues.is_empty() {
        ui.weak("The validator found nothing to report.");
        return;
    }
    egui::CollapsingHeader::new(format!("Issues ({})", report.issues.len()))
        .id_salt("validation")
        .default_open(true)
        .show(ui, |ui| {
            egui::ScrollArea::vertical().id_salt("validation-issues").max_height(180.0).show(ui, |ui| {
                for issue in &report.issues {
                    ui.horizontal_wrapped(|ui| {
                        ui.label(egui::RichText::new(issue.severity_name()).color(colour(issue.severity)).strong());
                        ui.monospace(&issue.code);
                        if !issue.pointer.is_empty() {
                            ui.monospace(&issue.pointer);
                        }
                        ui.label(&issue.message);
                    });
                }
                if report.truncated {
                    ui.weak("The validator stopped listing issues here.");
                }
            });
        });
}
