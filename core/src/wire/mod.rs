//! Byte layouts shared by the core's tools, each defined once here and read or written by both
//! ends: [`frame_store`], a recorded drive as a camera's frame memory would hold it (the host
//! writes it, the firmware replays it), and [`trace`], the bit patterns of each estimate that the
//! host and the firmware print, compared bit for bit.

pub mod frame_store;
pub mod trace;

use crate::config::{Config, Settings};
use crate::projection::{Camera, Mount};

/// Words of a [`Config`] in a binary layout: the camera, the mount and the settings, each in
/// declaration order.
pub const CONFIG_WORDS: usize = Camera::WORDS + Mount::WORDS + Settings::WORDS;

/// `config` as words, exactly (floats by their bits).
pub fn config_words(config: &Config) -> [u32; CONFIG_WORDS] {
    let mut out = [0u32; CONFIG_WORDS];
    let parts = [
        &config.camera.to_words()[..],
        &config.mount.to_words()[..],
        &config.settings.to_words()[..],
    ];
    for (slot, w) in out.iter_mut().zip(parts.into_iter().flatten()) {
        *slot = *w;
    }
    out
}

/// The [`Config`] [`config_words`] made; `None` where a word makes no value of its setting's
/// type (the configuration is still to be validated).
pub fn config_from_words(words: &[u32; CONFIG_WORDS]) -> Option<Config> {
    let (camera, rest) = words.split_first_chunk::<{ Camera::WORDS }>()?;
    let (mount, rest) = rest.split_first_chunk::<{ Mount::WORDS }>()?;
    let settings = rest.first_chunk::<{ Settings::WORDS }>()?;
    Some(Config {
        camera: Camera::from_words(camera)?,
        mount: Mount::from_words(mount)?,
        settings: Settings::from_words(settings)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::tests::kitti_config;

    #[test]
    fn a_config_comes_back_from_its_words_bit_for_bit() {
        let mut c = kitti_config();
        c.settings.method = crate::Method::Paper;
        c.settings.refine_heading = true;
        c.settings.pitch_steps = 7;
        c.mount.pitch_rad = -0.0192;
        let w = config_words(&c);
        assert_eq!(config_from_words(&w), Some(c));
        let mut bad = w;
        // The method's word (the settings' first) names no method.
        bad[Camera::WORDS + Mount::WORDS] = 7;
        assert_eq!(config_from_words(&bad), None);
    }
}
