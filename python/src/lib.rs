//! The `roadvo` Python package, for analysing drives in notebooks: mount files
//! ([`PyMountFile`]), the odometer frame by frame on numpy images ([`PyOdometer`]), a KITTI
//! sequence run as `roadvo run` runs it ([`run`]), pose files ([`read_poses`], [`write_poses`])
//! and the KITTI metric ([`evaluate`]). Everything is the host tools' own code
//! (`roadvo_sim`); errors are raised as [`RoadvoError`] with the message the command line
//! would print.

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use pyo3::{IntoPyObjectExt, create_exception};
use roadvo::setting::{Field, Value};
use roadvo::{Camera, Instant, Mount, Settings, SliceFrame};
use roadvo_sim::kitti::{self, MAX_TIME_S, Pose, Sequence};
use roadvo_sim::mount::{MountFile, camera_of_sequence};
use roadvo_sim::run::{QualityLine, config_error, mount_for, run_sequence};
use std::path::PathBuf;

create_exception!(
    roadvo,
    RoadvoError,
    PyValueError,
    "What roadvo refused or could not do: a file that cannot be read or is wrong (the message \
     names it), a configuration out of range, a frame of the wrong size or time."
);

/// `e` as a [`RoadvoError`], its whole chain of causes in the message.
fn error(e: impl Into<anyhow::Error>) -> PyErr {
    RoadvoError::new_err(format!("{:#}", e.into()))
}

/// A setting's value as Python has it; a number as the mount file writes it (the shortest
/// decimal that reads back to the same `f32`), a method by its name.
fn value_to_py(py: Python<'_>, v: Value) -> PyResult<Bound<'_, PyAny>> {
    match v {
        Value::F32(x) => format!("{x:?}")
            .parse::<f64>()
            .unwrap_or(f64::NAN)
            .into_bound_py_any(py),
        Value::U8(x) => x.into_bound_py_any(py),
        Value::U16(x) => x.into_bound_py_any(py),
        Value::U32(x) => x.into_bound_py_any(py),
        Value::Bool(b) => b.into_bound_py_any(py),
        Value::Method(m) => m.name().into_bound_py_any(py),
    }
}

/// One section of a mount file as a dict: each of `fields` by its key, in the file's unit.
fn section<'py>(
    py: Python<'py>,
    fields: &[Field],
    get: impl Fn(&str) -> Option<Value>,
) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    for f in fields {
        if let Some(v) = get(f.key) {
            dict.set_item(f.key, value_to_py(py, v)?)?;
        }
    }
    Ok(dict)
}

/// Poses as an (N, 12) array of float64, one KITTI pose (the 3x4 `[R | t]`, row-major) a row.
fn poses_to_py<'py>(py: Python<'py>, poses: &[Pose]) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_fn((poses.len(), 12), |(i, k)| poses[i][k]).into_pyarray(py)
}

/// Poses from an (N, 12) array, one KITTI pose a row; `what` names it in errors.
fn poses_from_py(poses: &PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<Vec<Pose>> {
    let shape = poses.shape();
    if shape[1] != 12 {
        return Err(RoadvoError::new_err(format!(
            "{what}: expected an (N, 12) array of KITTI poses, got shape ({}, {})",
            shape[0], shape[1]
        )));
    }
    let a = poses.as_array();
    Ok(a.rows()
        .into_iter()
        .map(|row| std::array::from_fn(|k| row[k]))
        .collect())
}

/// A mount file: the camera, where it sits in the vehicle and the odometer's settings
/// (docs/mount-file.md). Its sections are dicts in the file's units (`camera`, `mount`,
/// `odometer`); `str()` gives the file's text.
#[pyclass(name = "MountFile", module = "roadvo")]
pub struct PyMountFile {
    inner: MountFile,
}

#[pymethods]
impl PyMountFile {
    /// Reads the mount file at `path`. A file without `[camera]` takes the camera of the KITTI
    /// sequence folder `sequence` (its calib.txt and frame size), and is refused without.
    #[staticmethod]
    #[pyo3(signature = (path, sequence=None))]
    fn read(path: PathBuf, sequence: Option<PathBuf>) -> PyResult<Self> {
        let camera = sequence
            .map(|dir| camera_of_sequence(&Sequence::open(&dir).map_err(error)?).map_err(error))
            .transpose()?;
        let inner = MountFile::read(&path, camera.as_ref()).map_err(error)?;
        Ok(Self { inner })
    }

    /// `[camera]`: the image size and the intrinsics, pixels.
    #[getter]
    fn camera<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        section(py, Camera::FIELDS, |k| self.inner.camera.get(k))
    }

    /// `[mount]`: where the camera sits in the vehicle frame, metres and degrees.
    #[getter]
    fn mount<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        section(py, Mount::FIELDS, |k| self.inner.mount.get(k))
    }

    /// `[odometer]`: every setting of the odometer, defaults included.
    #[getter]
    fn odometer<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        section(py, Settings::FIELDS, |k| self.inner.settings.get(k))
    }

    /// Changes one value as a line of the file would: `"KEY=VALUE"` in `[odometer]`, or
    /// `"SECTION.KEY=VALUE"` (`roadvo run --set`); nothing changes on an error.
    fn set(&mut self, assignment: &str) -> PyResult<()> {
        self.inner.set(assignment).map_err(error)
    }

    /// Writes the file to `path`, with its `[camera]` section unless `with_camera` is false.
    #[pyo3(signature = (path, with_camera=true))]
    fn write(&self, path: PathBuf, with_camera: bool) -> PyResult<()> {
        self.inner.write(&path, with_camera, "").map_err(error)
    }

    /// The file's text, `[camera]` included.
    fn __str__(&self) -> String {
        self.inner.to_text(true, "")
    }
}

/// The odometer of a mount file, fed one grey image at a time.
#[pyclass(name = "Odometer", module = "roadvo")]
pub struct PyOdometer {
    odometer: Box<roadvo::Odometer>,
    /// Estimates returned so far.
    estimates: usize,
}

#[pymethods]
impl PyOdometer {
    /// An odometer for `mount`, whose configuration must be valid.
    #[new]
    fn new(mount: &PyMountFile) -> PyResult<Self> {
        let config = mount
            .inner
            .to_config()
            .validate()
            .map_err(|e| error(config_error(e)))?;
        let odometer = roadvo::Odometer::new(config).map_err(|e| error(config_error(e)))?;
        Ok(Self {
            odometer: Box::new(odometer),
            estimates: 0,
        })
    }

    /// Processes one frame: a 2-D uint8 array (rows of grey pixels, the mount's camera size)
    /// taken at `t_s` seconds (0 to 1e9, at least a microsecond after the last frame). Returns
    /// its estimate as the lines of `roadvo run --quality` hold it: `frame` (the estimates
    /// before it), `time_s`, the motion since the last frame (`heading_change_rad`,
    /// `distance_m`), the vehicle's pose in the first frame's vehicle frame (`x_m`, `y_m`,
    /// `heading_rad`) and the quality figures. A refused frame changes nothing.
    fn process<'py>(
        &mut self,
        py: Python<'py>,
        frame: PyReadonlyArray2<'py, u8>,
        t_s: f64,
    ) -> PyResult<Bound<'py, PyAny>> {
        if !(0.0..=MAX_TIME_S).contains(&t_s) {
            return Err(RoadvoError::new_err(format!(
                "time {t_s} s is outside 0 to {MAX_TIME_S:e} s"
            )));
        }
        let (height, width) = (frame.shape()[0], frame.shape()[1]);
        let (Ok(w), Ok(h)) = (u16::try_from(width), u16::try_from(height)) else {
            return Err(RoadvoError::new_err(format!(
                "the frame is {width}x{height} pixels: at most 65535 either way"
            )));
        };
        let contiguous;
        let bytes = match frame.as_slice() {
            Ok(b) => b,
            Err(_) => {
                contiguous = frame.as_array().iter().copied().collect::<Vec<u8>>();
                &contiguous
            }
        };
        let frame = SliceFrame::new(bytes, w, h, width)
            .ok_or_else(|| RoadvoError::new_err("the frame's buffer is too short"))?;
        let t = Instant::from_micros(kitti::micros(t_s));
        let estimate = self.odometer.process(&frame, t).map_err(error)?;
        let line = QualityLine::of(self.estimates, t_s, &estimate, &self.odometer);
        self.estimates += 1;
        Ok(pythonize::pythonize(py, &line)?)
    }

    /// The vehicle's pose after the last frame, in the first frame's vehicle frame (x forward,
    /// y left, heading counter-clockwise): `x_m`, `y_m`, `heading_rad`.
    #[getter]
    fn pose<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let p = self.odometer.pose();
        let dict = PyDict::new(py);
        dict.set_item("x_m", p.x_m)?;
        dict.set_item("y_m", p.y_m)?;
        dict.set_item("heading_rad", p.heading_rad)?;
        Ok(dict)
    }

    /// The camera's KITTI pose after the last frame (12 numbers, the 3x4 `[R | t]` row-major)
    /// through the mount as learned so far: as `roadvo run` writes it without a smoother, which
    /// lifts every frame through the mount learned by the drive's end (the same where nothing
    /// was learned: `learn_yaw`, `learn_pitch`, `learn_roll` and `learn_x` off).
    #[getter]
    fn camera_pose<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let lift = self.odometer.config().lift();
        let pose = kitti::pose_of(&lift.camera_pose(&self.odometer.pose()));
        pose.to_vec().into_pyarray(py)
    }

    /// Forgets every frame: the next one starts a new trajectory at the origin.
    fn reset(&mut self) {
        self.odometer.reset();
        self.estimates = 0;
    }
}

/// Runs the KITTI-layout sequence folder `seq_dir` (image_0/, times.txt, calib.txt) with the
/// mount file at `mount_path` (default: `seq_dir/mount.toml`; without `[camera]` it takes the
/// sequence's), as `roadvo run` does: returns the camera-0 poses it writes, an (N, 12) array,
/// smoothed as the mount file says. A frame that cannot be read or is refused is an error.
#[pyfunction]
#[pyo3(signature = (seq_dir, mount_path=None))]
fn run(
    py: Python<'_>,
    seq_dir: PathBuf,
    mount_path: Option<PathBuf>,
) -> PyResult<Bound<'_, PyArray2<f64>>> {
    let poses = py
        .detach(|| {
            let seq = Sequence::open(&seq_dir)?;
            let mount = mount_for(&seq, mount_path.as_deref())?;
            anyhow::Ok(run_sequence(&seq, &mount, None)?.poses)
        })
        .map_err(error)?;
    Ok(poses_to_py(py, &poses))
}

/// Reads a KITTI pose file: an (N, 12) array.
#[pyfunction]
fn read_poses(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyArray2<f64>>> {
    let poses = kitti::read_poses(&path).map_err(error)?;
    Ok(poses_to_py(py, &poses))
}

/// Writes an (N, 12) array of poses as a KITTI pose file, as `roadvo run --out` does.
#[pyfunction]
fn write_poses(path: PathBuf, poses: PyReadonlyArray2<'_, f64>) -> PyResult<()> {
    kitti::write_poses(&path, &poses_from_py(&poses, "poses")?).map_err(error)
}

/// The KITTI metric of the estimated poses `est_poses` against the ground truth `gt_poses`
/// (each an (N, 12) array), with the figures `roadvo eval` adds: a dict (`t_err_pct`,
/// `r_err_deg_per_m`, `segments`, `per_length`, the short-segment and scaled figures,
/// `path_ratio`, `end_drift_pct`, ...).
#[pyfunction]
fn evaluate<'py>(
    py: Python<'py>,
    gt_poses: PyReadonlyArray2<'py, f64>,
    est_poses: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let gt = poses_from_py(&gt_poses, "gt_poses")?;
    let est = poses_from_py(&est_poses, "est_poses")?;
    let report = roadvo_sim::eval::evaluate(&gt, &est).map_err(error)?;
    Ok(pythonize::pythonize(py, &report)?)
}

/// The `roadvo` module.
#[pymodule(name = "roadvo")]
fn roadvo_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("RoadvoError", m.py().get_type::<RoadvoError>())?;
    m.add_class::<PyMountFile>()?;
    m.add_class::<PyOdometer>()?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(read_poses, m)?)?;
    m.add_function(wrap_pyfunction!(write_poses, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
