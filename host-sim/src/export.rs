//! `roadvo export-config`: a mount file's whole configuration as source for a target, a Rust
//! `const roadvo::Config` or a C array of the words `roadvo_configure` reads (the C API's
//! `capi/include/roadvo.h`), so that a firmware runs exactly the settings the host runs.
//!
//! Both are written from the core's own lists ([`Camera::FIELDS`], [`Mount::FIELDS`],
//! [`Settings::FIELDS`] and their `to_words`), every setting with its key and its value as the
//! mount file writes it beside the exact bits: a setting added to the core appears in the next
//! export, and an export older than the core fails to build (a missing field in Rust, a wrong
//! count of words in C).

use roadvo::setting::{Field, Value};
use roadvo::wire::CONFIG_WORDS;
use roadvo::{Camera, Config, Mount, Settings};
use std::fmt::Write;

/// The language of an export.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Language {
    /// `pub const NAME: roadvo::Config = ...;`
    Rust,
    /// `static const uint32_t NAME[] = { ... };` and a check of its length.
    C,
}

/// One section of a configuration: its name in a mount file, the core's struct, the field of
/// [`Config`] holding it, its settings and their words and values.
struct Section {
    file: &'static str,
    rust_type: &'static str,
    config_field: &'static str,
    fields: &'static [Field],
    words: Vec<u32>,
    values: Vec<Option<Value>>,
}

fn sections(config: &Config) -> [Section; 3] {
    let values = |fields: &[Field], get: &dyn Fn(&str) -> Option<Value>| {
        fields.iter().map(|f| get(f.key)).collect()
    };
    [
        Section {
            file: "camera",
            rust_type: "Camera",
            config_field: "camera",
            fields: Camera::FIELDS,
            words: config.camera.to_words().to_vec(),
            values: values(Camera::FIELDS, &|k| config.camera.get(k)),
        },
        Section {
            file: "mount",
            rust_type: "Mount",
            config_field: "mount",
            fields: Mount::FIELDS,
            words: config.mount.to_words().to_vec(),
            values: values(Mount::FIELDS, &|k| config.mount.get(k)),
        },
        Section {
            file: "odometer",
            rust_type: "Settings",
            config_field: "settings",
            fields: Settings::FIELDS,
            words: config.settings.to_words().to_vec(),
            values: values(Settings::FIELDS, &|k| config.settings.get(k)),
        },
    ]
}

/// A value as a mount file writes it (for the comments).
fn file_text(v: Option<Value>) -> String {
    match v {
        Some(Value::F32(x)) => format!("{x:?}"),
        Some(Value::U8(x)) => x.to_string(),
        Some(Value::U16(x)) => x.to_string(),
        Some(Value::U32(x)) => x.to_string(),
        Some(Value::Bool(b)) => b.to_string(),
        Some(Value::Method(m)) => format!("\"{}\"", m.name()),
        None => "?".into(),
    }
}

/// `config` as source in `language`, named `name`, `header` (comment lines, without the comment
/// markers) at the top.
pub fn export(config: &Config, language: Language, name: &str, header: &[String]) -> String {
    match language {
        Language::Rust => rust(config, name, header),
        Language::C => c(config, name, header),
    }
}

fn rust(config: &Config, name: &str, header: &[String]) -> String {
    let mut out = String::new();
    for line in header {
        let _ = writeln!(out, "// {line}");
    }
    let _ = writeln!(
        out,
        "\n/// The configuration, every setting at its exact bits (the mount file's value in the \
         comment).\n#[rustfmt::skip]\npub const {name}: roadvo::Config = roadvo::Config {{"
    );
    for s in sections(config) {
        let _ = writeln!(out, "    {}: roadvo::{} {{", s.config_field, s.rust_type);
        for ((f, w), v) in s.fields.iter().zip(&s.words).zip(&s.values) {
            let literal = match v {
                Some(Value::F32(_)) => format!("f32::from_bits({w:#010x})"),
                Some(Value::Bool(b)) => b.to_string(),
                Some(Value::Method(m)) => format!("roadvo::Method::{m:?}"),
                _ => w.to_string(),
            };
            let _ = writeln!(
                out,
                "        {}: {literal}, // {} = {}",
                f.name,
                f.key,
                file_text(*v)
            );
        }
        let _ = writeln!(out, "    }},");
    }
    let _ = writeln!(out, "}};");
    out
}

fn c(config: &Config, name: &str, header: &[String]) -> String {
    let mut out = String::from("/*\n");
    for line in header {
        let _ = writeln!(out, " * {line}");
    }
    let guard = format!("{}_H", name.to_uppercase());
    let _ = writeln!(
        out,
        " */\n#ifndef {guard}\n#define {guard}\n\n#include <stdint.h>\n\n#include \"roadvo.h\"\n\n\
         /* The words roadvo_configure() reads: [camera], [mount], [odometer], each setting in \
         the core's order,\n   floats by their bits (the mount file's value in the comment). */\n\
         static const uint32_t {name}[] = {{"
    );
    for s in sections(config) {
        for ((f, w), v) in s.fields.iter().zip(&s.words).zip(&s.values) {
            let _ = writeln!(
                out,
                "    {w:#010x}u, /* [{}] {} = {} */",
                s.file,
                f.key,
                file_text(*v)
            );
        }
    }
    let _ = writeln!(
        out,
        "}};\n\n/* Where each setting is among the words, to change one at run time (a mount \
         calibrated in the\n   vehicle, say) before roadvo_configure() checks them all. */"
    );
    let mut index = 0;
    for s in sections(config) {
        for f in s.fields {
            let _ = writeln!(
                out,
                "#define ROADVO_CONFIG_{}_{} {index}",
                s.file.to_uppercase(),
                f.key.to_uppercase()
            );
            index += 1;
        }
    }
    let _ = writeln!(
        out,
        "\n_Static_assert(sizeof {name} / sizeof {name}[0] == ROADVO_CONFIG_WORDS,\n    \
         \"{name} was exported for another set of settings ({CONFIG_WORDS} words): export it \
         again\");\n\n#endif /* {guard} */"
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use roadvo::wire::config_words;

    fn config() -> Config {
        let camera = Camera::KITTI_00;
        let mut c = Config::with_defaults(
            camera,
            Mount {
                x_m: 0.875,
                height_m: 1.565,
                pitch_rad: -1.1f32.to_radians(),
                ..Mount::DEFAULT
            },
        );
        c.settings.refine_heading = true;
        c.settings.method = roadvo::Method::Paper;
        c
    }

    #[test]
    fn the_c_export_holds_every_word_in_order() {
        let c = config();
        let text = export(&c, Language::C, "cfg", &["a test".into()]);
        let words: Vec<u32> = text
            .lines()
            .filter_map(|l| l.trim().strip_prefix("0x"))
            .map(|l| u32::from_str_radix(&l[..8], 16).unwrap())
            .collect();
        assert_eq!(words, config_words(&c).to_vec());
        assert!(text.contains("/* [mount] pitch_deg = -1.1 */"), "{text}");
        assert!(
            text.contains("/* [odometer] method = \"paper\" */"),
            "{text}"
        );
    }

    #[test]
    fn the_rust_export_names_every_setting_with_its_bits() {
        let c = config();
        let text = export(&c, Language::Rust, "CONFIG", &[]);
        let fields = Camera::FIELDS.len() + Mount::FIELDS.len() + Settings::FIELDS.len();
        assert_eq!(text.matches(" // ").count(), fields, "{text}");
        let bits = format!("f32::from_bits({:#010x})", c.mount.pitch_rad.to_bits());
        assert!(
            text.contains(&format!("pitch_rad: {bits}, // pitch_deg = -1.1")),
            "{text}"
        );
        assert!(text.contains("method: roadvo::Method::Paper,"), "{text}");
        assert!(text.contains("refine_heading: true,"), "{text}");
    }
}
