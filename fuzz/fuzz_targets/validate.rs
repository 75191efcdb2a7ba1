//! `Config::validate` on arbitrary settings (every float any bit pattern: NaN, infinities,
//! subnormals; every count any value its type holds), and an odometer on what passes, fed
//! three frames of its size. Nothing may panic.
#![no_main]

use arbitrary::Unstructured;
use libfuzzer_sys::fuzz_target;
use roadvo::setting::{Field, Value};
use roadvo::{Camera, Config, Instant, Method, Mount, Odometer, Settings, SliceFrame};

/// A value of `like`'s type, any the type holds.
fn any_like(like: Value, u: &mut Unstructured) -> arbitrary::Result<Value> {
    Ok(match like {
        Value::F32(_) => Value::F32(f32::from_bits(u.arbitrary()?)),
        Value::U8(_) => Value::U8(u.arbitrary()?),
        Value::U16(_) => Value::U16(u.arbitrary()?),
        Value::U32(_) => Value::U32(u.arbitrary()?),
        Value::Bool(_) => Value::Bool(u.arbitrary()?),
        Value::Method(_) => Value::Method(*u.choose(&Method::ALL)?),
    })
}

/// Sets every field of a section through its key, as a mount file would.
fn fill(
    fields: &[Field],
    get: impl Fn(&str) -> Option<Value>,
    mut set: impl FnMut(&str, Value),
    u: &mut Unstructured,
) -> arbitrary::Result<()> {
    for f in fields {
        if let Some(like) = get(f.key) {
            set(f.key, any_like(like, u)?);
        }
    }
    Ok(())
}

fn config(u: &mut Unstructured) -> arbitrary::Result<Config> {
    let (mut camera, mut mount, mut settings) =
        (Camera::DEFAULT, Mount::DEFAULT, Settings::DEFAULT);
    let c = camera;
    fill(
        Camera::FIELDS,
        |k| c.get(k),
        |k, v| {
            let _ = camera.set(k, v);
        },
        u,
    )?;
    let m = mount;
    fill(
        Mount::FIELDS,
        |k| m.get(k),
        |k, v| {
            let _ = mount.set(k, v);
        },
        u,
    )?;
    let s = settings;
    fill(
        Settings::FIELDS,
        |k| s.get(k),
        |k, v| {
            let _ = settings.set(k, v);
        },
        u,
    )?;
    Ok(Config {
        camera,
        mount,
        settings,
    })
}

fuzz_target!(|data: &[u8]| {
    let mut u = Unstructured::new(data);
    let Ok(config) = config(&mut u) else {
        return;
    };
    let Ok(valid) = config.validate() else {
        return;
    };
    let Ok(mut odometer) = Odometer::<128, 32, 64>::new(valid).map(Box::new) else {
        return;
    };
    let size = valid.config().camera;
    let (w, h) = (usize::from(size.width_px), usize::from(size.height_px));
    if w * h > 4 << 20 {
        return;
    }
    let pixels: Vec<u8> = (0..w * h).map(|i| ((i * 7919) >> 3) as u8).collect();
    let frame = SliceFrame::new(&pixels, w as u16, h as u16, w).expect("buffer fits");
    for t in [0, 100_000, 200_000] {
        let _ = odometer.process(&frame, Instant::from_micros(t));
    }
});
