//! `docs/mount-file.md` against the code: each section's table lists exactly the keys the core
//! defines for it, with the code's unit of angle, default and range, so that the one reference
//! of the mount file cannot drift from the settings it describes.

use roadvo::setting::{Field, Unit, Value};
use roadvo::{Camera, Method, Mount, Settings};

const DOC: &str = include_str!("../../docs/mount-file.md");

/// One row of a section's table: key, unit, default, range (the meaning is not checked).
#[derive(Debug)]
struct Row {
    key: String,
    unit: String,
    default: String,
    range: String,
}

/// The rows of the table under the heading ``## `[section]` ``.
fn rows(section: &str) -> Vec<Row> {
    let heading = format!("## `[{section}]`");
    let start = DOC
        .lines()
        .position(|l| l.trim() == heading)
        .unwrap_or_else(|| panic!("docs/mount-file.md has no heading {heading}"));
    let mut out = Vec::new();
    for line in DOC.lines().skip(start + 1) {
        if line.starts_with("## ") {
            break;
        }
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        // "| a | b | c | d | e |" splits into seven cells, empty at both ends.
        if cells.len() != 7 || !cells[1].starts_with('`') {
            continue;
        }
        out.push(Row {
            key: cells[1].trim_matches('`').to_owned(),
            unit: cells[2].to_owned(),
            default: cells[3].to_owned(),
            range: cells[4].to_owned(),
        });
    }
    assert!(!out.is_empty(), "no table rows under {heading}");
    out
}

/// The smallest and largest values a setting's type holds, for a bound the code leaves open.
fn type_bounds(v: Value) -> (f64, f64) {
    match v {
        Value::U8(_) => (0.0, f64::from(u8::MAX)),
        Value::U16(_) => (0.0, f64::from(u16::MAX)),
        Value::U32(_) => (0.0, f64::from(u32::MAX)),
        _ => (f64::NEG_INFINITY, f64::INFINITY),
    }
}

/// What is wrong with `row` as the documentation of `field`, whose default is `default`.
fn mismatches(section: &str, field: &Field, default: Value, row: &Row) -> Vec<String> {
    let mut wrong = Vec::new();
    let mut say = |what: String| wrong.push(format!("[{section}] {}: {what}", field.key));
    // The unit: degrees exactly where the file writes degrees.
    let degrees = row.unit.starts_with("deg");
    if degrees != (field.unit == Unit::Degrees) {
        say(format!(
            "unit {:?}, but the code's unit is {:?}",
            row.unit, field.unit
        ));
    }
    // The default, in the file's unit; "required" where the file must give it.
    if field.required || row.default == "required" {
        if !(field.required && row.default == "required") {
            say(format!(
                "default {:?}, but required is {}",
                row.default, field.required
            ));
        }
    } else {
        let documented = match default {
            Value::F32(_) => row.default.parse::<f32>().ok().map(Value::F32),
            Value::U8(_) => row.default.parse().ok().map(Value::U8),
            Value::U16(_) => row.default.parse().ok().map(Value::U16),
            Value::U32(_) => row.default.parse().ok().map(Value::U32),
            Value::Bool(_) => row.default.parse().ok().map(Value::Bool),
            Value::Method(_) => Method::from_name(row.default.trim_matches('`')).map(Value::Method),
        };
        if documented != Some(default) {
            say(format!(
                "default {:?}, the code's is {default:?}",
                row.default
            ));
        }
    }
    // The range, in the file's unit.
    match default {
        Value::Bool(_) => {
            if row.range != "`true`, `false`" {
                say(format!("range {:?}, expected `true`, `false`", row.range));
            }
        }
        Value::Method(_) => {
            let names: Vec<String> = Method::ALL
                .iter()
                .map(|m| format!("`{}`", m.name()))
                .collect();
            if row.range != names.join(", ") {
                say(format!(
                    "range {:?}, expected {}",
                    row.range,
                    names.join(", ")
                ));
            }
        }
        _ => {
            let (type_lo, type_hi) = type_bounds(default);
            let lo = field.min.map_or(type_lo, f64::from);
            let hi = field.max.map_or(type_hi, f64::from);
            let open = if field.min_exclusive { '(' } else { '[' };
            let parsed = row
                .range
                .strip_suffix(']')
                .and_then(|r| r.split_once(", "))
                .and_then(|(l, h)| {
                    let bracket = l.chars().next()?;
                    Some((
                        bracket,
                        l.get(1..)?.parse::<f64>().ok()?,
                        h.parse::<f64>().ok()?,
                    ))
                });
            if parsed != Some((open, lo, hi)) {
                say(format!(
                    "range {:?}, the code's is {open}{lo}, {hi}]",
                    row.range
                ));
            }
        }
    }
    wrong
}

/// Checks one section: every key listed exists, every key that exists is listed, once, and each
/// row agrees with the code.
fn check(section: &str, fields: &[Field], get: impl Fn(&str) -> Option<Value>) -> Vec<String> {
    let rows = rows(section);
    let mut wrong = Vec::new();
    for row in &rows {
        if rows.iter().filter(|r| r.key == row.key).count() > 1 {
            wrong.push(format!("[{section}] {}: listed twice", row.key));
        }
        match (fields.iter().find(|f| f.key == row.key), get(&row.key)) {
            (Some(field), Some(default)) => wrong.extend(mismatches(section, field, default, row)),
            _ => wrong.push(format!("[{section}] {}: listed, but no such key", row.key)),
        }
    }
    for field in fields {
        if !rows.iter().any(|r| r.key == field.key) {
            wrong.push(format!("[{section}] {}: a key, but not listed", field.key));
        }
    }
    wrong
}

#[test]
fn the_mount_file_reference_lists_every_key_with_the_codes_unit_default_and_range() {
    let mut wrong = check("camera", Camera::FIELDS, |k| Camera::DEFAULT.get(k));
    wrong.extend(check("mount", Mount::FIELDS, |k| Mount::DEFAULT.get(k)));
    wrong.extend(check("odometer", Settings::FIELDS, |k| {
        Settings::DEFAULT.get(k)
    }));
    assert!(
        wrong.is_empty(),
        "docs/mount-file.md disagrees with the code:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn the_check_catches_a_wrong_default_and_a_missing_key() {
    // A row with another default, and a section that lacks a key, must both be reported.
    let field = Settings::FIELDS
        .iter()
        .find(|f| f.key == "window_far_m")
        .expect("window_far_m is a setting");
    let row = Row {
        key: "window_far_m".into(),
        unit: "m".into(),
        default: "15.0".into(),
        range: "(0, 200]".into(),
    };
    let default = Settings::DEFAULT.get("window_far_m").expect("a default");
    assert_eq!(mismatches("odometer", field, default, &row).len(), 1);
    let fewer: Vec<Field> = Mount::FIELDS
        .iter()
        .copied()
        .chain(std::iter::once(Field {
            key: "lens_m",
            ..Mount::FIELDS[0]
        }))
        .collect();
    let wrong = check("mount", &fewer, |k| {
        Mount::DEFAULT.get(k).or(Some(Value::F32(0.0)))
    });
    assert_eq!(wrong, ["[mount] lens_m: a key, but not listed"]);
}
