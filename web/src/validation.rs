//! The Khronos glTF-Validator's report on the shown model, as the side panel lists it. The
//! element runs the validator (`validate()` in `kloub-viewer.js`, in a worker, fetched on first
//! use) and hands the viewer a summary as JSON ([`parse`]).

use serde_json::Value;

/// A validator run on one model: its report, or why there is none.
#[derive(Clone, Debug, PartialEq)]
pub struct Validation {
    /// The model's file name (a report for another model is dropped).
    pub name: String,
    /// The report, or the reason the validator could not run.
    pub outcome: Result<Report, String>,
}

/// The validator's counts and its first issues.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Report {
    /// The validator's version.
    pub validator: String,
    /// Issues per severity.
    pub errors: u32,
    /// Warnings.
    pub warnings: u32,
    /// Infos.
    pub infos: u32,
    /// Hints.
    pub hints: u32,
    /// Whether the validator stopped listing issues (its limit).
    pub truncated: bool,
    /// The issues, in the validator's order (at most 500).
    pub issues: Vec<Issue>,
}

/// One issue of the report.
#[derive(Clone, Debug, PartialEq)]
pub struct Issue {
    /// 0 error, 1 warning, 2 info, 3 hint.
    pub severity: u8,
    /// The validator's code, e.g. `ACCESSOR_INDEX_OOB`.
    pub code: String,
    /// The JSON pointer it is about (may be empty).
    pub pointer: String,
    /// The validator's message.
    pub message: String,
}

impl Issue {
    /// The severity's name.
    pub fn severity_name(&self) -> &'static str {
        match self.severity {
            0 => "error",
            1 => "warning",
            2 => "info",
            _ => "hint",
        }
    }
}

/// Reads the element's summary: `{name, error}` when the validator could not run, else
/// `{name, validator, errors, warnings, infos, hints, truncated, issues: [{severity, code,
/// pointer, message}]}`.
pub fn parse(json: &str) -> Result<Validation, String> {
    let v: Value = serde_json::from_str(json).map_err(|e| format!("setValidation: not JSON: {e}"))?;
    let text = |key: &str| v.get(key).and_then(Value::as_str).unwrap_or_default().to_owned();
    let count = |key: &str| v.get(key).and_then(Value::as_u64).map_or(0, |n| u32::try_from(n).unwrap_or(u32::MAX));
    let name = text("name");
    if let Some(error) = v.get("error").and_then(Value::as_str) {
        return Ok(Validation { name, outcome: Err(error.to_owned()) });
    }
    let issues = v
        .get("issues")
        .and_then(Value::as_array)
        .ok_or("setValidation: expected an issues array")?
        .iter()
        .take(500)
        .map(|i| {
            let field = |key: &str| i.get(key).and_then(Value::as_str).unwrap_or_default().to_owned();
            Issue {
                severity: i.get("severity").and_then(Value::as_u64).map_or(3, |s| s.min(3) as u8),
                code: field("code"),
                pointer: field("pointer"),
                message: field("message"),
            }
        })
        .collect();
    let report = Report {
        validator: text("validator"),
        errors: count("errors"),
        warnings: count("warnings"),
        infos: count("infos"),
        hints: count("hints"),
        truncated: v.get("truncated").and_then(Value::as_bool).unwrap_or(false),
        issues,
    };
    Ok(Validation { name, outcome: Ok(report) })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_elements_summary_reads_back() {
        let v = parse(
            r#"{"name":"a.glb","validator":"2.0.0-dev.3.10","errors":1,"warnings":2,"infos":0,"hints":3,"truncated":false,
               "issues":[{"severity":0,"code":"ACCESSOR_INDEX_OOB","pointer":"/meshes/0/primitives/0/indices","message":"out of range"}]}"#,
        )
        .expect("valid");
        assert_eq!(v.name, "a.glb");
        let report = v.outcome.expect("a report");
        assert_eq!((report.errors, report.warnings, report.infos, report.hints), (1, 2, 0, 3));
        assert_eq!(report.issues[0].severity_name(), "error");
        assert_eq!(report.issues[0].pointer, "/meshes/0/primitives/0/indices");
        let failed = parse(r#"{"name":"a.glb","error":"validate: HTTP 404"}"#).expect("valid");
        assert_eq!(failed.outcome, Err("validate: HTTP 404".to_owned()));
        assert!(parse("[1]").is_err());
        assert!(parse("not json").is_err());
    }
}
