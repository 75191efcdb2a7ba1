//! One definition per setting: the `settings!` macro declares a struct of
//! settings and, from the same lines, its defaults, an all-zero placeholder, the names and units
//! a mount file writes them in, access by those names, and the range check that validation runs.
//!
//! A mount file writes angles in degrees where the core keeps radians ([`Unit::Degrees`]); every
//! other setting is written in the core's own unit. The key a file uses is the core's field name
//! with `_rad` written `_deg`.

/// A setting's value, of whichever type it has.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Value {
    /// A real number.
    F32(f32),
    /// A small count.
    U8(u8),
    /// A count.
    U16(u16),
    /// A large count or threshold.
    U32(u32),
    /// A switch.
    Bool(bool),
    /// The estimator ([`crate::Method`]), by its name in a mount file.
    Method(crate::Method),
}

/// How a mount file writes a setting, against the core's unit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Unit {
    /// As the core keeps it.
    Same,
    /// Degrees in the file, radians in the core.
    Degrees,
}

/// Radians a degree.
pub const RAD_PER_DEG: f32 = core::f32::consts::PI / 180.0;

impl Unit {
    /// A value in the file's unit, in the core's.
    pub const fn to_core(self, file: f32) -> f32 {
        match self {
            Self::Same => file,
            Self::Degrees => file * RAD_PER_DEG,
        }
    }

    /// A value in the core's unit, in the file's: for degrees the value with the fewest
    /// decimals that converts back to `core` exactly, where one within six decimals does (so
    /// that a file written from the core's settings reads back bit for bit).
    pub fn to_file(self, core: f32) -> f32 {
        match self {
            Self::Same => core,
            Self::Degrees => {
                let raw = core.to_degrees();
                let exact = |c: f32| (c * RAD_PER_DEG).to_bits() == core.to_bits();
                (0..=6)
                    .map(|k| {
                        let scale = libm::pow(10.0, f64::from(k));
                        (libm::round(f64::from(raw) * scale) / scale) as f32
                    })
                    .find(|&c| exact(c))
                    .unwrap_or(raw)
            }
        }
    }

    fn value_to_core(self, v: Value) -> Value {
        match v {
            Value::F32(x) => Value::F32(self.to_core(x)),
            other => other,
        }
    }

    fn value_to_file(self, v: Value) -> Value {
        match v {
            Value::F32(x) => Value::F32(self.to_file(x)),
            other => other,
        }
    }
}

/// What a mount file needs to know of one setting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Field {
    /// Its key in a mount file.
    pub key: &'static str,
    /// Its name in the core's struct (and in [`crate::ConfigError`]).
    pub name: &'static str,
    /// The file's unit against the core's.
    pub unit: Unit,
    /// Its documentation, one line a line.
    pub doc: &'static [&'static str],
    /// A mount file must give it (no default serves every vehicle).
    pub required: bool,
    /// Smallest value accepted, in the file's unit (`None`: no lower bound).
    pub min: Option<f32>,
    /// A value must lie above `min`, not at it.
    pub min_exclusive: bool,
    /// Largest value accepted, in the file's unit (`None`: no upper bound).
    pub max: Option<f32>,
}

/// Why a setting could not be set by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum SetError {
    /// No setting has that key.
    UnknownKey,
    /// The value is not of the setting's type (or does not fit it).
    WrongType,
}

/// A type a setting can have.
pub trait SettingType: Copy {
    /// The placeholder of an unconfigured odometer: all zero bits.
    const ZERO: Self;
    /// As a [`Value`].
    fn to_value(self) -> Value;
    /// From a [`Value`] of this type; an integer of another width where it fits, and an integer
    /// for a real number, as a file may write `2` for `2.0`.
    fn from_value(v: Value) -> Option<Self>;
    /// As a real number, for the range check (`None`: not a number).
    fn to_f32(self) -> Option<f32>;
    /// As a 32-bit word, exactly (a float's bits), for a binary layout.
    fn to_word(self) -> u32;
    /// From a word [`to_word`](Self::to_word) made; `None` for a word no value makes.
    fn from_word(w: u32) -> Option<Self>;
}

impl SettingType for f32 {
    const ZERO: Self = 0.0;
    fn to_value(self) -> Value {
        Value::F32(self)
    }
    fn from_value(v: Value) -> Option<Self> {
        match v {
            Value::F32(x) => Some(x),
            Value::U8(x) => Some(f32::from(x)),
            Value::U16(x) => Some(f32::from(x)),
            Value::U32(x) => Some(x as f32),
            Value::Bool(_) | Value::Method(_) => None,
        }
    }
    fn to_f32(self) -> Option<f32> {
        Some(self)
    }
    fn to_word(self) -> u32 {
        self.to_bits()
    }
    fn from_word(w: u32) -> Option<Self> {
        Some(f32::from_bits(w))
    }
}

/// The integer inside `v`, if it is one.
fn integer(v: Value) -> Option<u32> {
    match v {
        Value::U8(x) => Some(u32::from(x)),
        Value::U16(x) => Some(u32::from(x)),
        Value::U32(x) => Some(x),
        Value::F32(_) | Value::Bool(_) | Value::Method(_) => None,
    }
}

macro_rules! integer_setting {
    ($t:ty, $variant:ident) => {
        // u32 to f32 rounds above 2^24; the range checks' bounds are far below.
        #[allow(clippy::cast_lossless)]
        impl SettingType for $t {
            const ZERO: Self = 0;
            fn to_value(self) -> Value {
                Value::$variant(self)
            }
            fn from_value(v: Value) -> Option<Self> {
                integer(v).and_then(|x| <$t>::try_from(x).ok())
            }
            fn to_f32(self) -> Option<f32> {
                Some(self as f32)
            }
            fn to_word(self) -> u32 {
                u32::from(self)
            }
            fn from_word(w: u32) -> Option<Self> {
                <$t>::try_from(w).ok()
            }
        }
    };
}
integer_setting!(u8, U8);
integer_setting!(u16, U16);
integer_setting!(u32, U32);

impl SettingType for bool {
    const ZERO: Self = false;
    fn to_value(self) -> Value {
        Value::Bool(self)
    }
    fn from_value(v: Value) -> Option<Self> {
        match v {
            Value::Bool(b) => Some(b),
            _ => None,
        }
    }
    fn to_f32(self) -> Option<f32> {
        None
    }
    fn to_word(self) -> u32 {
        u32::from(self)
    }
    fn from_word(w: u32) -> Option<Self> {
        match w {
            0 => Some(false),
            1 => Some(true),
            _ => None,
        }
    }
}

impl SettingType for crate::Method {
    const ZERO: Self = crate::Method::PitchVote;
    fn to_value(self) -> Value {
        Value::Method(self)
    }
    fn from_value(v: Value) -> Option<Self> {
        match v {
            Value::Method(m) => Some(m),
            _ => None,
        }
    }
    fn to_f32(self) -> Option<f32> {
        None
    }
    fn to_word(self) -> u32 {
        match self {
            crate::Method::PitchVote => 0,
            crate::Method::Paper => 1,
        }
    }
    fn from_word(w: u32) -> Option<Self> {
        match w {
            0 => Some(crate::Method::PitchVote),
            1 => Some(crate::Method::Paper),
            _ => None,
        }
    }
}

/// A value in a mount file, by its type (a method by its name).
#[cfg(feature = "serde")]
pub struct FileValue(pub Value);

#[cfg(feature = "serde")]
impl serde::Serialize for FileValue {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self.0 {
            Value::F32(x) => s.serialize_f32(x),
            Value::U8(x) => s.serialize_u8(x),
            Value::U16(x) => s.serialize_u16(x),
            Value::U32(x) => s.serialize_u32(x),
            Value::Bool(b) => s.serialize_bool(b),
            Value::Method(m) => s.serialize_str(m.name()),
        }
    }
}

/// Reads a section's key as its index among `.0`, the section's keys; an unknown key is an
/// error that lists the known ones.
#[cfg(feature = "serde")]
pub struct KeySeed(pub &'static [&'static str]);

#[cfg(feature = "serde")]
impl<'de> serde::de::DeserializeSeed<'de> for KeySeed {
    type Value = usize;
    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<usize, D::Error> {
        d.deserialize_identifier(self)
    }
}

#[cfg(feature = "serde")]
impl serde::de::Visitor<'_> for KeySeed {
    type Value = usize;
    fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("a setting's key")
    }
    fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<usize, E> {
        self.0
            .iter()
            .position(|k| *k == v)
            .ok_or_else(|| E::unknown_field(v, self.0))
    }
}

/// Whether `v` (in the core's unit) lies in `field`'s range: finite, and within its bounds.
pub(crate) fn in_range(field: &Field, v: f32) -> bool {
    let lo = field.min.map(|m| field.unit.to_core(m));
    let hi = field.max.map(|m| field.unit.to_core(m));
    v.is_finite()
        && lo.is_none_or(|lo| if field.min_exclusive { v > lo } else { v >= lo })
        && hi.is_none_or(|hi| v <= hi)
}

/// A value for a setting's default, in the file's unit: angles in degrees, converted here.
pub(crate) const fn deg(file_deg: f32) -> f32 {
    Unit::Degrees.to_core(file_deg)
}

/// A value for a setting's default, in the core's unit.
pub(crate) const fn val<T: Copy>(v: T) -> T {
    v
}

/// Declares a struct of settings. Each field is written once:
///
/// ```text
/// /// What it is, with the paper's value and why this default.
/// name_rad: f32 = deg(1.0), min 0.0, max 10.0 => "name_deg";
/// ```
///
/// `deg(x)` gives a default in degrees (a [`Unit::Degrees`] field: radians in the core), `val(x)`
/// in the core's unit; `required` after it marks a field a mount file must give; `min`, `above` (an
/// exclusive minimum) and `max` bound it, in the file's unit. The macro makes the struct, its
/// `DEFAULT` and all-zero `ZERO`, `FIELDS` (key, unit, documentation, bounds), `get` and `set`
/// by key (in the file's unit), and `check_finite` and `check_ranges` (the first field that is
/// not finite, or not within its bounds, by its name).
macro_rules! settings {
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $(
                $(#[doc = $doc:literal])*
                $field:ident : $ty:ty = $unit:ident ( $default:expr )
                    $($required:ident)?
                    $(, min $min:literal)?
                    $(, above $above:literal)?
                    $(, max $max:literal)?
                    => $key:literal;
            )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Copy, Debug, PartialEq)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub struct $name {
            $(
                $(#[doc = $doc])*
                pub $field: $ty,
            )*
        }

        impl $name {
            /// Every setting at its documented default.
            pub const DEFAULT: Self = Self {
                $( $field: $crate::setting::$unit($default), )*
            };

            /// Every bit zero: the placeholder of an unconfigured odometer.
            pub const ZERO: Self = Self {
                $( $field: <$ty as $crate::setting::SettingType>::ZERO, )*
            };

            /// The settings as a mount file writes them, in declaration order.
            pub const FIELDS: &'static [$crate::setting::Field] = &[
                $(
                    $crate::setting::Field {
                        key: $key,
                        name: stringify!($field),
                        unit: $crate::setting::settings!(@unit $unit),
                        doc: &[$($doc),*],
                        required: false $(|| stringify!($required).len() > 0)?,
                        min: $crate::setting::settings!(@bound $($min)? $($above)?),
                        min_exclusive: false $(|| { let _ = $above; true })?,
                        max: $crate::setting::settings!(@bound $($max)?),
                    },
                )*
            ];

            /// How many settings the struct holds: its words in a binary layout.
            pub const WORDS: usize = Self::FIELDS.len();

            /// The settings as words, exactly (floats by their bits), in declaration order.
            pub fn to_words(&self) -> [u32; Self::WORDS] {
                use $crate::setting::SettingType;
                [$( self.$field.to_word() ),*]
            }

            /// The settings from words [`to_words`](Self::to_words) made; `None` where a word
            /// makes no value of its setting's type.
            pub fn from_words(words: &[u32; Self::WORDS]) -> Option<Self> {
                use $crate::setting::SettingType;
                let mut w = words.iter();
                Some(Self {
                    $( $field: <$ty>::from_word(*w.next()?)?, )*
                })
            }

            /// The setting a mount file calls `key`, in the file's unit.
            pub fn get(&self, key: &str) -> Option<$crate::setting::Value> {
                use $crate::setting::SettingType;
                match key {
                    $( $key => Some($crate::setting::settings!(@unit $unit)
                        .file_value(self.$field.to_value())), )*
                    _ => None,
                }
            }

            /// Sets the setting a mount file calls `key` to `value`, given in the file's unit.
            /// Nothing changes on an error.
            pub fn set(
                &mut self,
                key: &str,
                value: $crate::setting::Value,
            ) -> Result<(), $crate::setting::SetError> {
                use $crate::setting::SettingType;
                match key {
                    $( $key => {
                        let v = $crate::setting::settings!(@unit $unit).core_value(value);
                        self.$field = <$ty>::from_value(v)
                            .ok_or($crate::setting::SetError::WrongType)?;
                        Ok(())
                    } )*
                    _ => Err($crate::setting::SetError::UnknownKey),
                }
            }

            /// The first setting that is not a finite number, by name.
            pub fn check_finite(&self) -> Result<(), &'static str> {
                use $crate::setting::SettingType;
                $(
                    if self.$field.to_f32().is_some_and(|v| !v.is_finite()) {
                        return Err(stringify!($field));
                    }
                )*
                Ok(())
            }

            /// The first setting that is not within its bounds, by name.
            pub fn check_ranges(&self) -> Result<(), &'static str> {
                use $crate::setting::SettingType;
                let mut fields = Self::FIELDS.iter();
                $(
                    if let (Some(v), Some(f)) = (self.$field.to_f32(), fields.next())
                        && !$crate::setting::in_range(f, v)
                    {
                        return Err(stringify!($field));
                    }
                )*
                Ok(())
            }
        }

        impl Default for $name {
            fn default() -> Self {
                Self::DEFAULT
            }
        }

        /// As a mount file's section: each setting by its key, in the file's unit.
        #[cfg(feature = "serde")]
        impl serde::Serialize for $name {
            fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                use serde::ser::SerializeMap;
                use $crate::setting::SettingType;
                let mut map = s.serialize_map(Some(Self::WORDS))?;
                $(
                    let v = $crate::setting::settings!(@unit $unit).file_value(self.$field.to_value());
                    map.serialize_entry($key, &$crate::setting::FileValue(v))?;
                )*
                map.end()
            }
        }

        /// From a mount file's section: every key known, every required one given, the others
        /// at their defaults; values in the file's unit. (Ranges are checked by validation.)
        #[cfg(feature = "serde")]
        impl<'de> serde::Deserialize<'de> for $name {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                struct Visitor;
                impl<'de> serde::de::Visitor<'de> for Visitor {
                    type Value = $name;
                    fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                        f.write_str(concat!("a table of ", stringify!($name), " settings"))
                    }
                    fn visit_map<A: serde::de::MapAccess<'de>>(
                        self,
                        mut map: A,
                    ) -> Result<$name, A::Error> {
                        use serde::de::Error;
                        use $crate::setting::SettingType;
                        const KEYS: &[&str] = &[$($key),*];
                        let mut out = $name::DEFAULT;
                        let mut given = [false; $name::WORDS];
                        while let Some(i) = map.next_key_seed($crate::setting::KeySeed(KEYS))? {
                            let key = KEYS.get(i).copied().unwrap_or_default();
                            if let Some(g) = given.get_mut(i) {
                                *g = true;
                            }
                            match key {
                                $( $key => {
                                    let v: $ty = map.next_value()?;
                                    let unit = $crate::setting::settings!(@unit $unit);
                                    out.$field = <$ty>::from_value(unit.core_value(v.to_value()))
                                        .ok_or_else(|| A::Error::custom(concat!("bad ", $key)))?;
                                } )*
                                _ => {}
                            }
                        }
                        for (f, given) in $name::FIELDS.iter().zip(given) {
                            if f.required && !given {
                                return Err(A::Error::missing_field(f.key));
                            }
                        }
                        Ok(out)
                    }
                }
                d.deserialize_map(Visitor)
            }
        }
    };
    (@unit deg) => { $crate::setting::Unit::Degrees };
    (@unit val) => { $crate::setting::Unit::Same };
    (@bound) => { None };
    (@bound $b:literal) => { Some($b as f32) };
}
pub(crate) use settings;

impl Unit {
    /// `v`, given in the file's unit, in the core's.
    pub fn core_value(self, v: Value) -> Value {
        self.value_to_core(v)
    }

    /// `v`, kept in the core's unit, in the file's.
    pub fn file_value(self, v: Value) -> Value {
        self.value_to_file(v)
    }
}
