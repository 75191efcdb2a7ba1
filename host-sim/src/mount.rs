//! The mount file (`mount.toml`): a vehicle's camera, where it sits and how the odometer runs,
//! as a user writes them: `[camera]`, `[mount]` and `[odometer]`, read straight into the core's
//! own types (`roadvo::Camera`, `Mount`, `Settings`, each setting defined once there). The keys,
//! units, defaults and ranges are listed in `docs/mount-file.md` (a test holds the two together).
//! `[camera]` may be left out where the sequence carries its calibration (KITTI's `calib.txt` and
//! the frames' size): one mount file then serves every sequence of a vehicle; or the file may
//! name an OpenCV calibration instead (`opencv_calibration = "FILE"` at its top,
//! [`crate::opencv_calib`]).

use crate::input::{Input, read_text};
use crate::kitti::Sequence;
use anyhow::{Context, Result, bail};
use roadvo::setting::Value;
use roadvo::{Camera, Config, ImageSize, Mount, Settings};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A whole mount file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MountFile {
    /// `[camera]`, or the sequence's where the file has none.
    pub camera: Camera,
    /// `[mount]`.
    pub mount: Mount,
    /// `[odometer]`.
    pub settings: Settings,
}

/// A mount file as written: `[camera]` may be missing, `[odometer]` holds what differs from the
/// defaults.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct MountFileText {
    /// An OpenCV calibration file that gives the camera, relative to the mount file.
    #[serde(skip_serializing_if = "Option::is_none")]
    opencv_calibration: Option<PathBuf>,
    #[serde(skip_serializing_if = "Option::is_none")]
    camera: Option<Camera>,
    mount: Mount,
    #[serde(default)]
    odometer: Settings,
}

/// The sections of a mount file and the keys each holds.
const SECTIONS: [(&str, &[roadvo::setting::Field]); 3] = [
    ("camera", Camera::FIELDS),
    ("mount", Mount::FIELDS),
    ("odometer", Settings::FIELDS),
];

/// The camera of a KITTI-layout sequence: `P0` of its `calib.txt` and its frames' size,
/// within the ranges the odometer takes; errors name `calib.txt` (or the frames), never the
/// mount file; an error for a sequence without `calib.txt` (a video, a folder of frames).
pub fn camera_of_sequence(seq: &Sequence) -> Result<Camera> {
    let Some(p0) = seq.p0 else {
        bail!("{}", crate::layout::no_calibration(seq));
    };
    let (w, h) = seq.size;
    let size = |v: u32, what| {
        u16::try_from(v).with_context(|| {
            format!(
                "{}: the frames are {v} pixels {what}, more than 65535",
                seq.dir.join("image_0").display()
            )
        })
    };
    let image = ImageSize {
        width_px: size(w, "wide")?,
        height_px: size(h, "high")?,
    };
    let camera = Camera::from_kitti_p0(image, &p0.map(|x| x as f32));
    if let Err(field) = camera.check_finite().and_then(|()| camera.check_ranges()) {
        let value = camera
            .get(field)
            .map_or(String::new(), |v| format!(" {}", toml_text(v)));
        bail!(
            "{}: P0 gives the camera {field}{value}, outside what the odometer takes \
             (docs/mount-file.md, [camera])",
            seq.dir.join("calib.txt").display()
        );
    }
    Ok(camera)
}

/// A mount file without a camera (no `[camera]` section, no `opencv_calibration`) read where
/// no sequence gives one.
#[derive(Debug, thiserror::Error)]
#[error(
    "mount file {} has no [camera] section, and there is no sequence to take the camera from",
    path.display()
)]
pub struct NoCamera {
    /// The mount file.
    pub path: PathBuf,
}

impl MountFile {
    /// Reads and parses a mount file; errors name the file, and the line for syntax errors and
    /// unknown keys. A file without `[camera]` takes `camera` (a sequence's calibration), and is
    /// refused without.
    pub fn read(path: &Path, camera: Option<&Camera>) -> Result<Self> {
        let text = read_text(path, Input::Mount).context("cannot read the mount file")?;
        Self::parse(&text, path, camera)
    }

    /// Parses the text of a mount file read from `path` (named in errors, with the line for
    /// syntax errors and unknown keys). A file without `[camera]` takes `camera`, and is
    /// refused without.
    pub fn parse(text: &str, path: &Path, camera: Option<&Camera>) -> Result<Self> {
        let file: MountFileText =
            toml::from_str(text).with_context(|| format!("in mount file {}", path.display()))?;
        let calibration = match (&file.opencv_calibration, &file.camera) {
            (Some(_), Some(_)) => bail!(
                "mount file {} has both opencv_calibration and [camera]: give the camera once",
                path.display()
            ),
            (Some(calib), None) => {
                let dir = path.parent().unwrap_or(Path::new(""));
                Some(
                    crate::opencv_calib::read(&dir.join(calib)).with_context(|| {
                        format!("opencv_calibration of mount file {}", path.display())
                    })?,
                )
            }
            (None, _) => None,
        };
        let Some(camera) = calibration.or(file.camera).or_else(|| camera.copied()) else {
            return Err(NoCamera {
                path: path.to_owned(),
            }
            .into());
        };
        Ok(Self {
            camera,
            mount: file.mount,
            settings: file.odometer,
        })
    }

    /// The file's text: a header that says what it is, `note` (comment lines) after it, then
    /// the sections; `[odometer]` holds the settings that differ from the defaults. Without
    /// `with_camera` the `[camera]` section is left out: each sequence's calibration then
    /// supplies it.
    pub fn to_text(&self, with_camera: bool, note: &str) -> String {
        let mut text = format!(
            "# roadvo mount file: the camera, where it sits in the vehicle frame (origin on the\n\
             # road under the rear-axle centre, x forward, y left, z up; angles in degrees) and\n\
             # the odometer's settings where they differ from the defaults. Keys:\n\
             # docs/mount-file.md.\n{note}"
        );
        for (section, fields) in SECTIONS {
            if section == "camera" && !with_camera {
                continue;
            }
            let lines: Vec<String> = fields
                .iter()
                .filter_map(|f| {
                    let v = self.get(section, f.key)?;
                    // Optional camera keys (the lens's distortion) and settings only where they
                    // differ from their defaults; the mount whole.
                    let default = match section {
                        "camera" => Camera::DEFAULT.get(f.key),
                        "odometer" => Settings::DEFAULT.get(f.key),
                        _ => None,
                    };
                    (f.required || default != Some(v))
                        .then(|| format!("{} = {}\n", f.key, toml_text(v)))
                })
                .collect();
            if !lines.is_empty() {
                text += &format!("\n[{section}]\n{}", lines.concat());
            }
        }
        text
    }

    /// Writes the file (see [`to_text`](Self::to_text)).
    pub fn write(&self, path: &Path, with_camera: bool, note: &str) -> Result<()> {
        crate::output::write_atomic(path, self.to_text(with_camera, note).as_bytes())
    }

    /// Sets one value as a line of the file would: `KEY=VALUE` in `[odometer]`, or
    /// `SECTION.KEY=VALUE` in `[camera]`, `[mount]` or `[odometer]`, the value written as in the
    /// file (`0`, `0.5`, `"paper"`, or a bare word for text): the `--set` option, for trying a
    /// setting without editing a file. Errors say which assignment and what was expected;
    /// nothing changes on an error.
    pub fn set(&mut self, assignment: &str) -> Result<()> {
        let context = || format!("--set {assignment}");
        let Some((path, text)) = assignment.split_once('=') else {
            bail!(
                "{}: expected KEY=VALUE, e.g. max_roll_change_steps=0",
                context()
            );
        };
        let path = path.trim();
        let (section, key) = path.split_once('.').unwrap_or(("odometer", path));
        let Some((_, fields)) = SECTIONS.iter().find(|(name, _)| *name == section) else {
            bail!(
                "{}: no section [{section}] (camera, mount or odometer)",
                context()
            );
        };
        let Some(field) = fields.iter().find(|f| f.key == key) else {
            bail!(
                "{}: [{section}] has no key `{key}` (docs/mount-file.md lists them)",
                context()
            );
        };
        // A word without quotes is taken as text (`method=paper`), as a shell user writes it.
        let text = text.trim();
        let parsed = toml::from_str::<toml::Table>(&format!("value = {text}"))
            .ok()
            .and_then(|mut t| t.remove("value"))
            .unwrap_or_else(|| toml::Value::String(text.to_owned()));
        let expected = self.get(section, key);
        let value = expected
            .and_then(|e| file_value(e, &parsed))
            .with_context(|| format!("{}: expected {}", context(), kind(expected)))?;
        let mut changed = *self;
        let result = match section {
            "camera" => changed.camera.set(key, value),
            "mount" => changed.mount.set(key, value),
            _ => changed.settings.set(key, value),
        };
        result.map_err(|e| anyhow::anyhow!("{}: {e:?} ({})", context(), field.key))?;
        *self = changed;
        Ok(())
    }

    /// The value of `key` in `section`, in the file's unit.
    fn get(&self, section: &str, key: &str) -> Option<Value> {
        match section {
            "camera" => self.camera.get(key),
            "mount" => self.mount.get(key),
            "odometer" => self.settings.get(key),
            _ => None,
        }
    }

    /// The core's configuration (not yet validated).
    pub fn to_config(&self) -> Config {
        Config {
            camera: self.camera,
            mount: self.mount,
            settings: self.settings,
        }
    }

    /// A mount value in the file's unit (degrees for angles): what `calibrate` varies.
    pub fn mount_value(&self, key: &str) -> f32 {
        match self.mount.get(key) {
            Some(Value::F32(x)) => x,
            _ => 0.0,
        }
    }

    /// Sets a mount value given in the file's unit.
    pub fn set_mount_value(&mut self, key: &str, file_value: f32) {
        let _ = self.mount.set(key, Value::F32(file_value));
    }
}

/// A value as a mount file writes it: the shortest decimal that reads back to the same `f32`.
fn toml_text(v: Value) -> String {
    match v {
        // TOML spells it `nan`; `{:?}` would write `NaN`, which does not read back.
        Value::F32(x) if x.is_nan() => "nan".to_owned(),
        Value::F32(x) => format!("{x:?}"),
        Value::U8(x) => x.to_string(),
        Value::U16(x) => x.to_string(),
        Value::U32(x) => x.to_string(),
        Value::Bool(b) => b.to_string(),
        Value::Method(m) => format!("\"{}\"", m.name()),
    }
}

/// What a setting of `expected`'s type takes, in words.
fn kind(expected: Option<Value>) -> &'static str {
    match expected {
        Some(Value::F32(_)) => "a number",
        Some(Value::U8(_)) => "a whole number from 0 to 255",
        Some(Value::U16(_)) => "a whole number from 0 to 65535",
        Some(Value::U32(_)) => "a whole number from 0 to 4294967295",
        Some(Value::Bool(_)) => "true or false",
        Some(Value::Method(_)) => "a method: pitch-vote or paper",
        None => "a known key",
    }
}

/// `v` as a value of `expected`'s type, if it is one.
fn file_value(expected: Value, v: &toml::Value) -> Option<Value> {
    Some(match (expected, v) {
        (Value::F32(_), toml::Value::Float(x)) => Value::F32(*x as f32),
        (Value::F32(_), toml::Value::Integer(x)) => Value::F32(*x as f32),
        (Value::U8(_), toml::Value::Integer(x)) => Value::U8(u8::try_from(*x).ok()?),
        (Value::U16(_), toml::Value::Integer(x)) => Value::U16(u16::try_from(*x).ok()?),
        (Value::U32(_), toml::Value::Integer(x)) => Value::U32(u32::try_from(*x).ok()?),
        (Value::Bool(_), toml::Value::Boolean(b)) => Value::Bool(*b),
        (Value::Method(_), toml::Value::String(s)) => Value::Method(roadvo::Method::from_name(s)?),
        _ => return None,
    })
}

/// The key of the setting the core calls `name` in a mount file, with its section: for
/// messages about a configuration the core refused.
pub fn file_key(name: &str) -> Option<String> {
    SECTIONS.iter().find_map(|(section, fields)| {
        let f = fields.iter().find(|f| f.name == name)?;
        Some(format!("[{section}] {}", f.key))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const KITTI: &str = r#"
[camera]
width_px = 1241
height_px = 376
fx_px = 718.856
fy_px = 718.856
cx_px = 607.1928
cy_px = 185.2157

[mount]
x_m = 1.0
height_m = 1.65
"#;

    #[test]
    fn opencv_calibration_gives_the_camera_relative_to_the_file() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("lens")).unwrap();
        let calib = dir.path().join("lens/calibration.yaml");
        std::fs::write(&calib, crate::opencv_calib::SAMPLE_YAML).unwrap();
        let mount = dir.path().join("mount.toml");
        let text = "opencv_calibration = \"lens/calibration.yaml\"\n\n[mount]\nx_m = 1.0\nheight_m = 1.4\n";
        std::fs::write(&mount, text).unwrap();
        let f = MountFile::read(&mount, None).unwrap();
        assert_eq!(
            f.camera,
            crate::opencv_calib::parse(crate::opencv_calib::SAMPLE_YAML).unwrap()
        );
        assert_eq!((f.camera.k1, f.camera.width_px), (-0.3, 1280));
        // Written out, the camera is inline, its distortion with it, and reads back the same.
        let written = f.to_text(true, "");
        assert!(
            written.contains("k1 = -0.3") && !written.contains("k3"),
            "{written}"
        );
        assert_eq!(parse(&written), f);
        // Both ways of giving the camera at once: refused.
        std::fs::write(
            &mount,
            format!("opencv_calibration = \"lens/calibration.yaml\"\n{KITTI}"),
        )
        .unwrap();
        let e = format!("{:#}", MountFile::read(&mount, None).unwrap_err());
        assert!(e.contains("both opencv_calibration and [camera]"), "{e}");
    }

    fn parse(text: &str) -> MountFile {
        let f: MountFileText = toml::from_str(text).unwrap();
        MountFile {
            camera: f.camera.unwrap(),
            mount: f.mount,
            settings: f.odometer,
        }
    }

    #[test]
    fn minimal_file_takes_the_defaults_and_validates() {
        let f = parse(KITTI);
        assert_eq!(f.settings, Settings::DEFAULT);
        assert_eq!(f.mount.y_m, 0.0);
        f.to_config().validate().unwrap();
    }

    #[test]
    fn written_file_reads_back_bit_for_bit() {
        let mut f = parse(KITTI);
        f.set("mount.pitch_deg=-1.1").unwrap();
        f.set("mount.yaw_deg=-0.1").unwrap();
        f.set("heading_window_deg=0.7").unwrap();
        f.set("method=paper").unwrap();
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("mount.toml");
        f.write(&p, true, "").unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.contains("pitch_deg = -1.1\n"), "{text}");
        // Only what differs from the defaults.
        assert!(text.contains("heading_window_deg = 0.7") && !text.contains("pitch_steps"));
        assert_eq!(MountFile::read(&p, None).unwrap(), f);
    }

    #[test]
    fn a_file_without_camera_takes_the_sequence_camera_or_says_it_has_none() {
        let shipped = concat!(env!("CARGO_MANIFEST_DIR"), "/../mounts/kitti.toml");
        let seq_camera = parse(KITTI).camera;
        let f = MountFile::read(Path::new(shipped), Some(&seq_camera)).unwrap();
        assert_eq!(f.camera, seq_camera);
        f.to_config().validate().unwrap();
        let e = format!(
            "{:#}",
            MountFile::read(Path::new(shipped), None).unwrap_err()
        );
        assert!(
            e.contains("kitti.toml") && e.contains("no [camera] section"),
            "{e}"
        );
    }

    #[test]
    fn a_setting_changes_one_value_as_a_line_of_the_file_would() {
        let mut f = parse(KITTI);
        let before = f;
        f.set("max_roll_change_steps=0").unwrap();
        f.set(" mount.roll_deg = 1.5 ").unwrap();
        f.set("odometer.method=\"paper\"").unwrap();
        f.set("method=paper").unwrap();
        // An integer where the file holds a decimal, as a file may write it.
        f.set("pitch_settle_s=2").unwrap();
        assert_eq!(f.settings.max_roll_change_steps, 0);
        assert_eq!(f.mount.roll_rad, 1.5f32.to_radians());
        assert_eq!(f.settings.method, roadvo::Method::Paper);
        assert_eq!(f.settings.pitch_settle_s, 2.0);
        f.settings = before.settings;
        f.mount.roll_rad = before.mount.roll_rad;
        assert_eq!(f, before);
    }

    #[test]
    fn a_bad_setting_says_which_and_why_and_changes_nothing() {
        let mut f = parse(KITTI);
        let before = f;
        for (assignment, says) in [
            ("max_roll_change_steps", "expected KEY=VALUE"),
            ("max_roll_change=0", "no key `max_roll_change`"),
            ("wheels.x_m=1", "no section [wheels]"),
            (
                "roll_steps=-1",
                "--set roll_steps=-1: expected a whole number",
            ),
            ("method=fast", "--set method=fast: expected a method"),
            (
                "mount.height_m=tall",
                "--set mount.height_m=tall: expected a number",
            ),
        ] {
            let e = format!("{:#}", f.set(assignment).unwrap_err());
            assert!(e.contains(says), "{assignment}: {e}");
        }
        assert_eq!(f, before);
    }

    #[test]
    fn a_nan_is_written_as_toml_spells_it_and_reads_back() {
        let p = Path::new("mount.toml");
        let text = KITTI.replace("x_m = 1.0", "x_m = nan");
        let f = MountFile::parse(&text, p, None).unwrap();
        let written = f.to_text(true, "");
        assert!(written.contains("x_m = nan\n"), "{written}");
        assert!(
            MountFile::parse(&written, p, None)
                .unwrap()
                .mount
                .x_m
                .is_nan()
        );
    }

    #[test]
    fn dev_zero_as_a_mount_file_is_refused_quickly() {
        let t = std::time::Instant::now();
        let e = format!(
            "{:#}",
            MountFile::read(Path::new("/dev/zero"), None).unwrap_err()
        );
        assert_eq!(
            e,
            "cannot read the mount file: /dev/zero: larger than 1 MiB (1048576 bytes) (the \
             limit for a mount file)"
        );
        assert!(t.elapsed().as_secs() < 5);
    }

    #[test]
    fn a_calib_camera_the_odometer_refuses_is_blamed_on_calib_txt() {
        let dir = tempfile::tempdir().unwrap();
        let seq = Sequence {
            dir: dir.path().join("00"),
            frames: 1,
            times_s: vec![0.0],
            p0: Some([
                2e5, 0.0, 600.0, 0.0, 0.0, 700.0, 180.0, 0.0, 0.0, 0.0, 1.0, 0.0,
            ]),
            size: (1241, 376),
            layout: crate::layout::Layout::Kitti,
        };
        let e = format!("{:#}", camera_of_sequence(&seq).unwrap_err());
        assert!(
            e.starts_with(&format!(
                "{}: P0 gives the camera fx_px 200000.0",
                dir.path().join("00/calib.txt").display()
            )),
            "{e}"
        );
        assert!(!e.contains("mount file"), "{e}");
    }

    #[test]
    fn unknown_key_is_reported_with_its_line() {
        let bad = KITTI.replace("height_m = 1.65", "height_m = 1.65\nheigth = 2");
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("mount.toml");
        std::fs::write(&p, bad).unwrap();
        let e = format!("{:#}", MountFile::read(&p, None).unwrap_err());
        assert!(e.contains("mount.toml") && e.contains("heigth"), "{e}");
        assert!(e.contains("line 13"), "{e}");
        let missing = KITTI.replace("height_m = 1.65", "");
        std::fs::write(&p, missing).unwrap();
        let e = format!("{:#}", MountFile::read(&p, None).unwrap_err());
        assert!(e.contains("missing field `height_m`"), "{e}");
    }
}
