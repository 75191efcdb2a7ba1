//! A folder or a glob of image files as the frames of a drive: the `.png`, `.jpg` and `.jpeg`
//! files of a folder, or those a pattern names (`*` and `?` in the file name only, e.g.
//! `drive/frame_*.jpg`), in natural order: `frame2.png` before `frame10.png`.

use std::cmp::Ordering;
use std::path::{Path, PathBuf};

/// The extensions taken as frames, lower case (matched without regard to case).
pub const EXTENSIONS: [&str; 3] = ["png", "jpg", "jpeg"];

/// Whether `path` names an image file by its extension.
pub fn is_image(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| EXTENSIONS.iter().any(|x| x.eq_ignore_ascii_case(e)))
}

/// Whether `path`'s file name is a pattern (holds `*` or `?`).
pub fn is_pattern(path: &Path) -> bool {
    path.file_name()
        .is_some_and(|n| n.to_string_lossy().contains(['*', '?']))
}

/// The folder the frames of `path` (a folder or a pattern) are in.
pub fn folder_of(path: &Path) -> PathBuf {
    if is_pattern(path) {
        match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_owned(),
            _ => PathBuf::from("."),
        }
    } else {
        path.to_owned()
    }
}

/// The image files of the folder `path`, or those the pattern `path` matches, in natural
/// order; empty where there is none. Errors name the folder that cannot be listed.
pub fn list(path: &Path) -> std::io::Result<Vec<PathBuf>> {
    let folder = folder_of(path);
    let pattern = is_pattern(path).then(|| path.file_name().unwrap_or_default().to_string_lossy());
    let mut files = Vec::new();
    for entry in std::fs::read_dir(&folder)? {
        let entry = entry?;
        let file = entry.path();
        let name = entry.file_name();
        let matched = pattern
            .as_deref()
            .is_none_or(|p| wildcard_match(p, &name.to_string_lossy()));
        if matched && is_image(&file) && file.is_file() {
            files.push(file);
        }
    }
    files.sort_by(|a, b| natural_cmp(&a.to_string_lossy(), &b.to_string_lossy()));
    Ok(files)
}

/// Whether `name` matches `pattern`, where `*` stands for any run of characters and `?` for
/// one.
pub fn wildcard_match(pattern: &str, name: &str) -> bool {
    let (p, n): (Vec<char>, Vec<char>) = (pattern.chars().collect(), name.chars().collect());
    // The classic two-pointer match, backtracking to the last `*`.
    let (mut i, mut j) = (0, 0);
    let mut star: Option<(usize, usize)> = None;
    while j < n.len() {
        if i < p.len() && (p[i] == '?' || p[i] == n[j]) {
            i += 1;
            j += 1;
        } else if i < p.len() && p[i] == '*' {
            star = Some((i, j));
            i += 1;
        } else if let Some((si, sj)) = star {
            i = si + 1;
            j = sj + 1;
            star = Some((si, sj + 1));
        } else {
            return false;
        }
    }
    p[i..].iter().all(|&c| c == '*')
}

/// Natural order: runs of digits compare by their value (`2` before `10`), the rest by
/// character; equal values with different zero padding fall back to the text.
pub fn natural_cmp(a: &str, b: &str) -> Ordering {
    let (mut a_rest, mut b_rest) = (a, b);
    loop {
        match (a_rest.chars().next(), b_rest.chars().next()) {
            (None, None) => return a.cmp(b),
            (None, Some(_)) => return Ordering::Less,
            (Some(_), None) => return Ordering::Greater,
            (Some(x), Some(y)) if x.is_ascii_digit() && y.is_ascii_digit() => {
                let (x_digits, x_tail) = split_digits(a_rest);
                let (y_digits, y_tail) = split_digits(b_rest);
                let (x_value, y_value) = (
                    x_digits.trim_start_matches('0'),
                    y_digits.trim_start_matches('0'),
                );
                let by_value = x_value
                    .len()
                    .cmp(&y_value.len())
                    .then_with(|| x_value.cmp(y_value));
                if by_value != Ordering::Equal {
                    return by_value;
                }
                (a_rest, b_rest) = (x_tail, y_tail);
            }
            (Some(x), Some(y)) => {
                if x != y {
                    return x.cmp(&y);
                }
                (a_rest, b_rest) = (&a_rest[x.len_utf8()..], &b_rest[y.len_utf8()..]);
            }
        }
    }
}

/// The leading run of ASCII digits of `s`, and what follows it.
fn split_digits(s: &str) -> (&str, &str) {
    s.split_at(s.find(|c: char| !c.is_ascii_digit()).unwrap_or(s.len()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_sort_by_value() {
        let mut names = vec![
            "frame10.png",
            "frame2.png",
            "frame1.png",
            "frame02.png",
            "a.png",
            "frame1b.png",
        ];
        names.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(
            names,
            [
                "a.png",
                "frame1.png",
                "frame1b.png",
                "frame02.png",
                "frame2.png",
                "frame10.png"
            ]
        );
    }

    #[test]
    fn wildcards_match_as_a_shell_would() {
        assert!(wildcard_match("*.jpg", "frame_0001.jpg"));
        assert!(wildcard_match("frame_??.png", "frame_12.png"));
        assert!(!wildcard_match("frame_??.png", "frame_123.png"));
        assert!(wildcard_match("*_*.png", "a_b_c.png"));
        assert!(!wildcard_match("*.png", "a.jpg"));
        assert!(wildcard_match("*", ""));
    }

    #[test]
    fn a_folder_lists_its_images_in_natural_order_and_a_pattern_its_matches() {
        let d = tempfile::tempdir().unwrap();
        for name in ["f10.png", "f9.JPG", "f1.jpeg", "notes.txt", "g1.png"] {
            std::fs::write(d.path().join(name), b"").unwrap();
        }
        std::fs::create_dir(d.path().join("sub.png")).unwrap();
        let names = |files: Vec<PathBuf>| -> Vec<String> {
            files
                .iter()
                .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
                .collect()
        };
        assert_eq!(
            names(list(d.path()).unwrap()),
            ["f1.jpeg", "f9.JPG", "f10.png", "g1.png"]
        );
        assert_eq!(
            names(list(&d.path().join("f*")).unwrap()),
            ["f1.jpeg", "f9.JPG", "f10.png"]
        );
        assert!(list(&d.path().join("*.gif")).unwrap().is_empty());
    }
}
