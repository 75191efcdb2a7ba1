// The configuration the example builds with when `ROADVO_CONFIG_RS` names no export (see
// `build.rs`): KITTI 00-02's camera 0 on its rig's setup mount, every odometer setting at its
// default. `scripts/firmware` builds with exports of the drives it replays instead:
//
//     roadvo export-config mounts/kitti.toml --seq SEQ --rust --out config.rs

/// The configuration.
pub const CONFIG: roadvo::Config = roadvo::Config {
    camera: roadvo::Camera::KITTI_00,
    mount: roadvo::Mount {
        x_m: 1.0,
        height_m: 1.65,
        ..roadvo::Mount::DEFAULT
    },
    settings: roadvo::Settings::DEFAULT,
};
