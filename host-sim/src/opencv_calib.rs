//! OpenCV calibration files: the camera of a `cv::FileStorage` file as `cv::calibrateCamera`'s
//! users write it (OpenCV's `calibration` sample among them), YAML (`%YAML:1.0`) or XML:
//! `image_width`, `image_height`, `camera_matrix` (3x3) and `distortion_coefficients` (`k1, k2,
//! p1, p2[, k3, ...]`), each matrix an `opencv-matrix` with `rows`, `cols`, `dt` and `data`.
//!
//! Only what such a file holds is read, by a small reader of its own rather than a YAML parser:
//! OpenCV's YAML is YAML 1.0 with its own tags (`!!opencv-matrix`), which general parsers refuse.

use anyhow::{Context, Result, bail, ensure};
use roadvo::Camera;
use std::path::Path;

/// Names the matrices go by, the first the one OpenCV's sample writes.
const CAMERA_MATRIX: [&str; 3] = ["camera_matrix", "cameraMatrix", "K"];
const DISTORTION: [&str; 4] = ["distortion_coefficients", "dist_coeffs", "distCoeffs", "D"];

/// Reads the camera of the OpenCV calibration file at `path`.
pub fn read(path: &Path) -> Result<Camera> {
    let text = crate::input::read_text(path, crate::input::Input::Calib)
        .context("cannot read the OpenCV calibration")?;
    parse(&text).with_context(|| format!("in OpenCV calibration {}", path.display()))
}

/// The camera of a calibration file's text.
pub fn parse(text: &str) -> Result<Camera> {
    let file: &dyn Storage = if text.trim_start().starts_with("%YAML") {
        &Yaml(text)
    } else if text.contains("<opencv_storage>") {
        &Xml(text)
    } else {
        bail!("neither OpenCV YAML (%YAML:1.0) nor XML (<opencv_storage>)");
    };
    let size = |key: &str| -> Result<u16> {
        let v = file.scalar(key).with_context(|| format!("no {key}"))?;
        v.parse()
            .with_context(|| format!("{key} {v:?} is not a pixel count"))
    };
    let k = matrix(file, &CAMERA_MATRIX)?;
    ensure!(k.len() == 9, "camera_matrix is not 3x3");
    let d = matrix(file, &DISTORTION)?;
    ensure!(
        d.len() >= 4,
        "distortion_coefficients has {} values, not 4 or more",
        d.len()
    );
    if let Some(extra) = d.iter().skip(5).find(|&&x| x != 0.0) {
        bail!(
            "distortion_coefficients beyond k3 ({extra}, the rational or thin-prism model) are not \
             supported"
        );
    }
    let at = |i: usize| d.get(i).copied().unwrap_or(0.0) as f32;
    Ok(Camera {
        width_px: size("image_width")?,
        height_px: size("image_height")?,
        fx_px: k[0] as f32,
        fy_px: k[4] as f32,
        cx_px: k[2] as f32,
        cy_px: k[5] as f32,
        k1: at(0),
        k2: at(1),
        p1: at(2),
        p2: at(3),
        k3: at(4),
    })
}

/// The data of the first of `names` the file holds, `rows * cols` numbers.
fn matrix(file: &dyn Storage, names: &[&str]) -> Result<Vec<f64>> {
    let name = names[0];
    let (rows, cols, data) = names
        .iter()
        .find_map(|n| file.matrix(n))
        .with_context(|| format!("no {name} matrix"))?;
    let count = |v: &str, what| -> Result<usize> {
        v.trim()
            .parse()
            .with_context(|| format!("{name} {what} {v:?} is not a count"))
    };
    let (rows, cols) = (count(rows, "rows")?, count(cols, "cols")?);
    let values = data
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<f64>()
                .with_context(|| format!("{name} data {s:?} is not a number"))
        })
        .collect::<Result<Vec<f64>>>()?;
    ensure!(
        values.len() == rows * cols,
        "{name} has {} values for {rows}x{cols}",
        values.len()
    );
    ensure!(
        values.iter().all(|x| x.is_finite()),
        "{name} holds a value that is not finite"
    );
    Ok(values)
}

/// A `cv::FileStorage` file's top-level nodes.
trait Storage {
    /// A scalar's text.
    fn scalar(&self, key: &str) -> Option<&str>;
    /// A matrix's rows, cols and data (numbers apart, brackets removed).
    fn matrix(&self, key: &str) -> Option<(&str, &str, &str)>;
}

/// OpenCV's YAML: `key: value` at the top level; a matrix `key: !!opencv-matrix` followed by its
/// indented `rows`, `cols`, `dt` and `data: [ ... ]` (the list may run over lines).
struct Yaml<'a>(&'a str);

impl<'a> Yaml<'a> {
    /// The value after `key:` on the first line that begins with it (past its indentation
    /// where `indented`, at the line's very start otherwise), and the text from that value on.
    fn node(&self, key: &str, indented: bool) -> Option<(&'a str, &'a str)> {
        let mut offset = 0;
        for line in self.0.split_inclusive('\n') {
            let start = offset;
            offset += line.len();
            let body = line.trim_start();
            if indented == (body.len() == line.len()) {
                continue;
            }
            if let Some(rest) = body.strip_prefix(key).and_then(|r| r.strip_prefix(':')) {
                let value_at = start + (line.len() - rest.len());
                return Some((rest.trim(), self.0.get(value_at..)?.trim_start()));
            }
        }
        None
    }
}

impl Storage for Yaml<'_> {
    fn scalar(&self, key: &str) -> Option<&str> {
        self.node(key, false).map(|(v, _)| v)
    }

    fn matrix(&self, key: &str) -> Option<(&str, &str, &str)> {
        let (tag, after) = self.node(key, false)?;
        if !tag.contains("opencv-matrix") {
            return None;
        }
        // The matrix's own lines: indented, up to the next top-level key.
        let end = after
            .split_inclusive('\n')
            .skip(1)
            .take_while(|l| l.starts_with(char::is_whitespace))
            .map(str::len)
            .sum::<usize>()
            + after.find('\n').map_or(after.len(), |n| n + 1);
        let own = Yaml(after.get(..end)?);
        let (rows, _) = own.node("rows", true)?;
        let (cols, _) = own.node("cols", true)?;
        // `data: [ ... ]`, the list possibly over several lines.
        let (_, data) = own.node("data", true)?;
        let data = data.strip_prefix('[')?;
        Some((rows, cols, data.get(..data.find(']')?)?))
    }
}

/// OpenCV's XML: `<opencv_storage>` holding `<key>value</key>`; a matrix
/// `<key type_id="opencv-matrix">` holding `<rows>`, `<cols>`, `<dt>` and `<data>`.
struct Xml<'a>(&'a str);

impl<'a> Xml<'a> {
    /// The contents of the first element `key` (its attributes skipped).
    fn element(&self, key: &str) -> Option<&'a str> {
        let text = self.0;
        let mut from = 0;
        loop {
            let open = from + text[from..].find(&format!("<{key}"))?;
            let after = &text[open + 1 + key.len()..];
            // `<key>` or `<key attr...>`, not `<keyword>`.
            if after.starts_with('>') || after.starts_with(char::is_whitespace) {
                let start = open + 1 + key.len() + after.find('>')? + 1;
                let end = start + text[start..].find(&format!("</{key}>"))?;
                return Some(text[start..end].trim());
            }
            from = open + 1;
        }
    }
}

impl Storage for Xml<'_> {
    fn scalar(&self, key: &str) -> Option<&str> {
        self.element(key)
    }

    fn matrix(&self, key: &str) -> Option<(&str, &str, &str)> {
        let own = Xml(self.element(key)?);
        Some((
            own.element("rows")?,
            own.element("cols")?,
            own.element("data")?,
        ))
    }
}

/// A calibration as OpenCV 4's `calibration` sample writes it (`cv::FileStorage`, YAML).
#[cfg(test)]
pub(crate) const SAMPLE_YAML: &str = "%YAML:1.0
---
calibration_time: \"Tue 03 Jun 2025 10:12:44 CEST\"
nframes: 25
image_width: 1280
image_height: 720
board_width: 9
board_height: 6
square_size: 2.5000000000000000e-02
flags: 0
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 6.4123456789012345e+02, 0., 6.3950000000000000e+02, 0.,
       6.4200000000000000e+02, 3.5950000000000000e+02, 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 1
   cols: 5
   dt: d
   data: [ -3.0000000000000000e-01, 1.0000000000000001e-01,
       1.0000000000000000e-03, -5.0000000000000001e-04, 0. ]
avg_reprojection_error: 2.1234567890123457e-01
";

#[cfg(test)]
mod tests {
    use super::*;

    use super::SAMPLE_YAML as YAML;

    /// The same calibration as `cv::FileStorage` writes it in XML.
    const XML: &str = "<?xml version=\"1.0\"?>
<opencv_storage>
<calibration_time>\"Tue 03 Jun 2025 10:12:44 CEST\"</calibration_time>
<image_width>1280</image_width>
<image_height>720</image_height>
<camera_matrix type_id=\"opencv-matrix\">
  <rows>3</rows>
  <cols>3</cols>
  <dt>d</dt>
  <data>
    6.4123456789012345e+02 0. 6.3950000000000000e+02 0.
    6.4200000000000000e+02 3.5950000000000000e+02 0. 0. 1.</data></camera_matrix>
<distortion_coefficients type_id=\"opencv-matrix\">
  <rows>1</rows>
  <cols>5</cols>
  <dt>d</dt>
  <data>
    -3.0000000000000000e-01 1.0000000000000001e-01 1.0000000000000000e-03
    -5.0000000000000001e-04 0.</data></distortion_coefficients>
<avg_reprojection_error>2.1234567890123457e-01</avg_reprojection_error>
</opencv_storage>
";

    fn expected() -> Camera {
        Camera {
            width_px: 1280,
            height_px: 720,
            fx_px: 641.234_57,
            fy_px: 642.0,
            cx_px: 639.5,
            cy_px: 359.5,
            k1: -0.3,
            k2: 0.1,
            p1: 0.001,
            p2: -0.0005,
            k3: 0.0,
        }
    }

    #[test]
    fn reads_opencv_yaml_and_xml_alike() {
        assert_eq!(parse(YAML).unwrap(), expected());
        assert_eq!(parse(XML).unwrap(), expected());
    }

    #[test]
    fn four_coefficients_leave_k3_zero_and_a_rational_model_is_refused() {
        let four = YAML
            .replace("cols: 5", "cols: 4")
            .replace("-5.0000000000000001e-04, 0. ]", "-5.0000000000000001e-04 ]");
        assert_eq!(parse(&four).unwrap(), expected());
        let eight = YAML.replace("cols: 5", "cols: 8").replace(
            "-5.0000000000000001e-04, 0. ]",
            "-5.0e-04, 0., 0.2, 0., 0. ]",
        );
        let e = format!("{:#}", parse(&eight).unwrap_err());
        assert!(e.contains("not supported"), "{e}");
    }

    #[test]
    fn a_wrong_file_says_what_is_missing() {
        let e = format!("{:#}", parse("image_width: 3").unwrap_err());
        assert!(e.contains("neither OpenCV YAML"), "{e}");
        let no_matrix = YAML.replace("camera_matrix", "intrinsics");
        let e = format!("{:#}", parse(&no_matrix).unwrap_err());
        assert!(e.contains("no camera_matrix"), "{e}");
        let short = YAML.replace("cols: 3", "cols: 2");
        let e = format!("{:#}", parse(&short).unwrap_err());
        assert!(e.contains("9 values for 3x2"), "{e}");
    }
}
