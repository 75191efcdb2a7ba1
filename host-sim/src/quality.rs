//! The per-frame quality file of `roadvo run --quality`: one record a frame, as JSON lines
//! (`.jsonl` or any other extension) or as CSV with a header (`.csv`), the same fields either
//! way; and the fields of it that `roadvo eval --plot` draws.

use crate::output::OutputFile;
use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A quality file's format, by its extension: CSV for `.csv`, JSON lines for any other.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QualityFormat {
    /// One JSON object a line.
    JsonLines,
    /// Comma-separated values, a header line naming the fields.
    Csv,
}

impl QualityFormat {
    /// The format of the file at `path`.
    pub fn of(path: &Path) -> Self {
        let csv = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
        if csv { Self::Csv } else { Self::JsonLines }
    }
}

/// Writes records to a quality file, whole or not at all ([`OutputFile`]).
pub struct QualityWriter {
    out: OutputFile,
    format: QualityFormat,
    header_written: bool,
}

impl QualityWriter {
    /// Starts writing `path`, in the format of its extension.
    pub fn create(path: &Path) -> Result<Self> {
        Ok(Self {
            out: OutputFile::create(path)?,
            format: QualityFormat::of(path),
            header_written: false,
        })
    }

    /// Writes one record (a struct of plain fields): a JSON line, or a CSV row (after a header
    /// of its field names, before the first).
    pub fn write<T: Serialize>(&mut self, record: &T) -> Result<()> {
        match self.format {
            QualityFormat::JsonLines => self.out.write_line(&serde_json::to_string(record)?),
            QualityFormat::Csv => {
                let mut w = csv::WriterBuilder::new()
                    .has_headers(!self.header_written)
                    .from_writer(Vec::new());
                w.serialize(record)?;
                let bytes = w.into_inner().map_err(|e| e.into_error())?;
                self.header_written = true;
                self.out.write_all(&bytes)
            }
        }
    }

    /// Renames the file into place ([`OutputFile::commit`]).
    pub fn commit(self) -> Result<()> {
        self.out.commit()
    }
}

/// The fields of a quality record that plots draw.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
pub struct QualitySample {
    /// Frame number in the sequence.
    pub frame: usize,
    /// Tracks matched into this frame.
    pub tracks_matched: u16,
    /// Share of the matched tracks that agree with the motion, 0..1.
    pub inlier_ratio: f32,
    /// Whether the frame fell back to the previous motion.
    pub fallback: bool,
}

/// Reads a quality file (JSON lines, or CSV for `.csv`); errors name the file and line.
pub fn read_quality(path: &Path) -> Result<Vec<QualitySample>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let samples = match QualityFormat::of(path) {
        QualityFormat::JsonLines => text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty())
            .map(|(i, l)| {
                serde_json::from_str(l)
                    .with_context(|| format!("{} line {}", path.display(), i + 1))
            })
            .collect::<Result<Vec<_>>>()?,
        QualityFormat::Csv => csv::Reader::from_reader(text.as_bytes())
            .deserialize()
            .enumerate()
            .map(|(i, r)| r.with_context(|| format!("{} line {}", path.display(), i + 2)))
            .collect::<Result<Vec<_>>>()?,
    };
    if samples.is_empty() {
        bail!("{}: holds no frames", path.display());
    }
    Ok(samples)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Serialize)]
    struct Record {
        frame: usize,
        time_s: f64,
        tracks_matched: u16,
        inlier_ratio: f32,
        fallback: bool,
    }

    fn records() -> Vec<Record> {
        (0..3)
            .map(|i| Record {
                frame: i,
                time_s: 0.1 * i as f64,
                tracks_matched: 40 + i as u16,
                inlier_ratio: 0.5,
                fallback: i == 2,
            })
            .collect()
    }

    #[test]
    fn both_formats_hold_the_same_fields() {
        let d = tempfile::tempdir().unwrap();
        let mut read = Vec::new();
        for name in ["q.jsonl", "q.csv"] {
            let path = d.path().join(name);
            let mut w = QualityWriter::create(&path).unwrap();
            for r in records() {
                w.write(&r).unwrap();
            }
            w.commit().unwrap();
            read.push(read_quality(&path).unwrap());
        }
        assert_eq!(read[0], read[1]);
        assert_eq!(read[0][2].tracks_matched, 42);
        assert!(read[0][2].fallback);
        let csv = std::fs::read_to_string(d.path().join("q.csv")).unwrap();
        assert!(
            csv.starts_with(
                "frame,time_s,tracks_matched,inlier_ratio,fallback\n0,0.0,40,0.5,false\n"
            ),
            "{csv}"
        );
    }

    #[test]
    fn a_bad_record_names_file_and_line() {
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join("q.csv");
        std::fs::write(
            &path,
            "frame,tracks_matched,inlier_ratio,fallback\n0,4,0.5,false\n1,x,0.5,true\n",
        )
        .unwrap();
        let e = format!("{:#}", read_quality(&path).unwrap_err());
        assert!(e.contains("q.csv line 3"), "{e}");
        let path = d.path().join("q.jsonl");
        std::fs::write(&path, "{\"frame\": 0}\n").unwrap();
        let e = format!("{:#}", read_quality(&path).unwrap_err());
        assert!(e.contains("q.jsonl line 1: missing field"), "{e}");
    }
}
