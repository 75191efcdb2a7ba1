//! What the text targets share: the input as UTF-8 (the readers refuse anything else before
//! parsing), and a path for the parsers' messages.

/// `data` as text, if it is UTF-8.
pub fn text(data: &[u8]) -> Option<&str> {
    std::str::from_utf8(data).ok()
}
