//! Declared options: each option is written once, as a field of a struct
//! declared with [`options!`] (name, type, default, domain, and the field's
//! doc comment as its documentation: where the default comes from), and
//! everything else derives from the declaration:
//!
//! - [`Options::specs`]: every key with its type, domain, default and
//!   documentation (for `--options` listings);
//! - [`Options::keys`]: the `key (domain), ...` line error messages list;
//! - [`Options::set`]: the `key=value` parser (numbers finite, integer
//!   ranges, `true|false`, `u64` seeds, closed enums by name); a refused
//!   value leaves the options as they were;
//! - [`Options::describe`]: one `key=value ...` line (for table footers),
//!   which [`Options::set`] reads back to the same values;
//! - [`Options::validate`]: the domains (and an optional cross-field check)
//!   of options built in code.
//!
//! A value type implements [`OptionValue`] (done here for the integers,
//! `f64`, `f32`, `bool`, `Option<T>` and `Vec<T>`; [`choice!`] does it for a
//! closed enum). A type of another crate is read through a [`Codec`]
//! (`via CODEC` on the field; [`choice!`] writes one for a foreign enum).
//!
//! ```
//! use bayestrack_options::{Options, OptionError, above, choice, options};
//!
//! /// How a run's error is computed.
//! #[derive(Debug, Clone, Copy, PartialEq)]
//! pub enum Metric {
//!     /// Root mean square.
//!     Rmse,
//!     /// Mean absolute.
//!     Mae,
//! }
//! choice! { Metric { Rmse = "rmse", Mae = "mae" } }
//!
//! options! {
//!     /// Options of an experiment.
//!     #[derive(Debug, Clone, PartialEq)]
//!     pub struct Config {
//!         /// Monte Carlo runs (the paper's sec. 4: 100).
//!         pub runs: usize = 100, in 1..=10_000;
//!         /// Per-run error.
//!         pub metric: Metric = Metric::Rmse;
//!         /// Measurement noise std (the paper's 0.1).
//!         pub noise: f64 = 0.1, in above(0.0);
//!         /// Seed of every random stream.
//!         pub seed: u64 = 1;
//!     }
//! }
//!
//! let mut c = Config::default();
//! c.set("runs", "20").unwrap();
//! c.set("metric", "mae").unwrap();
//! assert_eq!(c.describe(), "runs=20 metric=mae noise=0.1 seed=1");
//! // a refused value names the key and its domain; an unknown key lists
//! // the valid ones
//! let e = c.set("runs", "0").unwrap_err();
//! assert!(matches!(e, OptionError::BadValue { .. }));
//! assert_eq!(e.to_string(), "bad value `0` for `runs`: expected 1..=10000");
//! let e = c.set("rnus", "5").unwrap_err();
//! assert!(e.to_string().contains("runs (1..=10000), metric (rmse|mae)"));
//! assert_eq!(c.runs, 20);
//! // describe -> set gives the same options
//! let mut d = Config::default();
//! d.set_all(&c.describe()).unwrap();
//! assert_eq!(c, d);
//! ```

use std::fmt::Display;
use std::ops::{Bound, RangeBounds};

/// What a refused `key=value` was, with the valid keys and their domains.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum OptionError {
    /// No option has this name.
    #[error("unknown option `{key}`; valid keys: {valid}")]
    UnknownKey {
        /// The name given.
        key: String,
        /// Every key with its domain ([`Options::keys`]).
        valid: String,
    },
    /// The value does not parse as the option's type or is outside its
    /// domain, or the options it would give fail their cross-field check.
    #[error("bad value `{value}` for `{key}`: {expected}")]
    BadValue {
        /// The option.
        key: String,
        /// The value given.
        value: String,
        /// What was expected (`expected` and the domain, or why the
        /// options are refused).
        expected: String,
        /// Every key with its domain ([`Options::keys`]); not in the
        /// message, which names the key's own domain.
        valid: String,
    },
    /// A `key=value` item of a list without `=`.
    #[error("expected key=value, got `{item}`")]
    NotKeyValue {
        /// The item.
        item: String,
    },
}

impl OptionError {
    /// The key named by the error (empty for [`OptionError::NotKeyValue`]).
    pub fn key(&self) -> &str {
        match self {
            Self::UnknownKey { key, .. } | Self::BadValue { key, .. } => key,
            Self::NotKeyValue { .. } => "",
        }
    }
}

/// A type an option can have: parsed from and written to one token.
pub trait OptionValue: Sized {
    /// The type's name in listings (`usize`, `f64`, `rmse|eq11`).
    const TYPE: &'static str;
    /// Parses a value; `None` when it is not one (non-finite numbers
    /// included).
    fn parse_option(s: &str) -> Option<Self>;
    /// Writes the value so that [`OptionValue::parse_option`] reads it back
    /// to the same value.
    fn format_option(&self) -> String;
    /// The domain of the type itself (`u64`, `finite`, `true|false`).
    fn domain() -> String {
        Self::TYPE.to_string()
    }
}

/// How options of type `T` are read and written: [`Native`] for an
/// [`OptionValue`]; [`choice!`] writes one for an enum of another crate.
pub trait Codec<T> {
    /// The type's name in listings.
    fn type_name() -> &'static str;
    /// Parses a value.
    fn parse(s: &str) -> Option<T>;
    /// Writes a value so that [`Codec::parse`] reads it back.
    fn format(v: &T) -> String;
    /// The type's domain.
    fn domain() -> String;
}

/// The [`Codec`] of every [`OptionValue`].
#[derive(Debug, Clone, Copy)]
pub struct Native;

impl<T: OptionValue> Codec<T> for Native {
    fn type_name() -> &'static str {
        T::TYPE
    }
    fn parse(s: &str) -> Option<T> {
        T::parse_option(s)
    }
    fn format(v: &T) -> String {
        v.format_option()
    }
    fn domain() -> String {
        T::domain()
    }
}

macro_rules! integer {
    ($($t:ty),*) => {$(
        impl OptionValue for $t {
            const TYPE: &'static str = stringify!($t);
            fn parse_option(s: &str) -> Option<Self> {
                s.trim().parse().ok()
            }
            fn format_option(&self) -> String {
                self.to_string()
            }
        }
    )*};
}
integer!(u8, u16, u32, u64, usize, i32, i64);

impl OptionValue for f64 {
    const TYPE: &'static str = "f64";
    fn parse_option(s: &str) -> Option<Self> {
        s.trim().parse::<f64>().ok().filter(|v| v.is_finite())
    }
    fn format_option(&self) -> String {
        // Rust writes the shortest digits that read back to the same f64
        self.to_string()
    }
    fn domain() -> String {
        "finite".into()
    }
}

impl OptionValue for f32 {
    const TYPE: &'static str = "f32";
    fn parse_option(s: &str) -> Option<Self> {
        let v = f64::parse_option(s)? as f32;
        v.is_finite().then_some(v)
    }
    fn format_option(&self) -> String {
        self.to_string()
    }
    fn domain() -> String {
        "finite".into()
    }
}

impl OptionValue for bool {
    const TYPE: &'static str = "bool";
    fn parse_option(s: &str) -> Option<Self> {
        s.trim().parse().ok()
    }
    fn format_option(&self) -> String {
        self.to_string()
    }
    fn domain() -> String {
        "true|false".into()
    }
}

/// `none` or a value.
impl<T: OptionValue> OptionValue for Option<T> {
    const TYPE: &'static str = "option";
    fn parse_option(s: &str) -> Option<Self> {
        if s.trim() == "none" {
            Some(None)
        } else {
            T::parse_option(s).map(Some)
        }
    }
    fn format_option(&self) -> String {
        self.as_ref()
            .map_or_else(|| "none".to_string(), T::format_option)
    }
    fn domain() -> String {
        format!("none or {}", T::domain())
    }
}

/// A comma-separated list of at least one value.
impl<T: OptionValue> OptionValue for Vec<T> {
    const TYPE: &'static str = "list";
    fn parse_option(s: &str) -> Option<Self> {
        s.split(',').map(T::parse_option).collect()
    }
    fn format_option(&self) -> String {
        let items: Vec<String> = self.iter().map(T::format_option).collect();
        items.join(",")
    }
    fn domain() -> String {
        format!("comma list of {}", T::domain())
    }
}

/// The values an option admits beyond its type (`in DOMAIN` in
/// [`options!`]): implemented for every range of `T` (`1..=10`, `0.0..`,
/// [`above`], [`above_to`], [`inside`]), [`Each`] and [`IfSome`].
pub trait Domain<T> {
    /// Whether `v` is in the domain.
    fn admits(&self, v: &T) -> bool;
    /// The domain in words (`1..=100000`, `> 0`).
    fn describe(&self) -> String;
}

impl<T: PartialOrd + Display, R: RangeBounds<T>> Domain<T> for R {
    fn admits(&self, v: &T) -> bool {
        self.contains(v)
    }
    fn describe(&self) -> String {
        use Bound::{Excluded, Included, Unbounded};
        match (self.start_bound(), self.end_bound()) {
            (Included(a), Included(b)) => format!("{a}..={b}"),
            (Included(a), Excluded(b)) => format!("{a}..{b}"),
            (Included(a), Unbounded) => format!(">= {a}"),
            (Excluded(a), Unbounded) => format!("> {a}"),
            (Excluded(a), Included(b)) => format!("> {a}, at most {b}"),
            (Excluded(a), Excluded(b)) => format!("{a} < v < {b}"),
            (Unbounded, Included(b)) => format!("<= {b}"),
            (Unbounded, Excluded(b)) => format!("< {b}"),
            (Unbounded, Unbounded) => "any".into(),
        }
    }
}

/// `v > lo`.
pub fn above<T>(lo: T) -> (Bound<T>, Bound<T>) {
    (Bound::Excluded(lo), Bound::Unbounded)
}

/// `lo < v <= hi`.
pub fn above_to<T>(lo: T, hi: T) -> (Bound<T>, Bound<T>) {
    (Bound::Excluded(lo), Bound::Included(hi))
}

/// `lo < v < hi`.
pub fn inside<T>(lo: T, hi: T) -> (Bound<T>, Bound<T>) {
    (Bound::Excluded(lo), Bound::Excluded(hi))
}

/// Every item of a list in the domain `D`.
#[derive(Debug, Clone, Copy)]
pub struct Each<D>(pub D);

impl<T, D: Domain<T>> Domain<Vec<T>> for Each<D> {
    fn admits(&self, v: &Vec<T>) -> bool {
        v.iter().all(|x| self.0.admits(x))
    }
    fn describe(&self) -> String {
        format!("comma list, each {}", self.0.describe())
    }
}

/// `none`, or a value in the domain `D`.
#[derive(Debug, Clone, Copy)]
pub struct IfSome<D>(pub D);

impl<T, D: Domain<T>> Domain<Option<T>> for IfSome<D> {
    fn admits(&self, v: &Option<T>) -> bool {
        v.as_ref().is_none_or(|x| self.0.admits(x))
    }
    fn describe(&self) -> String {
        format!("none or {}", self.0.describe())
    }
}

/// One declared option, as listed by `--options`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Spec {
    /// The key (the field's name).
    pub key: &'static str,
    /// The type's name (`usize`, `f64`, `rmse|eq11`).
    pub ty: &'static str,
    /// The values it admits (`1..=100000`, `finite`).
    pub domain: String,
    /// The declared default, as [`Options::set`] reads it.
    pub default: String,
    /// The field's doc comment: what it is and where the default comes
    /// from.
    pub doc: String,
}

impl Display for Spec {
    /// `key: type (domain) = default`, then the documentation indented.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {} ({}) = {}",
            self.key, self.ty, self.domain, self.default
        )?;
        for line in self.doc.lines() {
            write!(f, "\n    {line}")?;
        }
        Ok(())
    }
}

/// A struct of declared options (written by [`options!`]).
pub trait Options: Sized + Clone {
    /// Every option, in declaration order.
    fn specs() -> Vec<Spec>;
    /// Every option's current value as [`Options::set`] reads it, in
    /// declaration order.
    fn values(&self) -> Vec<(&'static str, String)>;
    /// Sets one option; a refused key or value (or options failing the
    /// cross-field check) leaves `self` as it was.
    ///
    /// # Errors
    /// [`OptionError::UnknownKey`], [`OptionError::BadValue`].
    fn set(&mut self, key: &str, value: &str) -> Result<(), OptionError>;
    /// Checks every option against its domain and the cross-field check.
    ///
    /// # Errors
    /// [`OptionError::BadValue`] naming the first option refused.
    fn validate(&self) -> Result<(), OptionError>;

    /// `key (domain), ...`: every key with its domain, for messages.
    fn keys() -> String {
        let items: Vec<String> = Self::specs()
            .iter()
            .map(|s| format!("{} ({})", s.key, s.domain))
            .collect();
        items.join(", ")
    }

    /// The current value of `key`, as [`Options::set`] reads it.
    fn get(&self, key: &str) -> Option<String> {
        self.values()
            .into_iter()
            .find(|(k, _)| *k == key)
            .map(|(_, v)| v)
    }

    /// `key=value key=value ...`, every option in declaration order; a
    /// value holds no space, so [`Options::set_all`] reads it back.
    fn describe(&self) -> String {
        let items: Vec<String> = self
            .values()
            .into_iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        items.join(" ")
    }

    /// Sets every `key=value` of a whitespace-separated list (as
    /// [`Options::describe`] writes), in order; stops at the first refused.
    ///
    /// # Errors
    /// As [`Options::set`]; [`OptionError::NotKeyValue`] for an item
    /// without `=`.
    fn set_all(&mut self, line: &str) -> Result<(), OptionError> {
        for item in line.split_whitespace() {
            let (k, v) = item
                .split_once('=')
                .ok_or_else(|| OptionError::NotKeyValue {
                    item: item.to_string(),
                })?;
            self.set(k, v)?;
        }
        Ok(())
    }
}

/// Two groups of options as one: the keys of `A`, then those of `B` (no
/// key may be in both); a value goes to the group that has its key, and
/// an error lists every key of the two. For a tracker's own options beside
/// a shared configuration (`particles` beside the ball trackers' settings).
impl<A: Options, B: Options> Options for (A, B) {
    fn specs() -> Vec<Spec> {
        let mut specs = A::specs();
        specs.extend(B::specs());
        specs
    }

    fn values(&self) -> Vec<(&'static str, String)> {
        let mut values = self.0.values();
        values.extend(self.1.values());
        values
    }

    fn set(&mut self, key: &str, value: &str) -> Result<(), OptionError> {
        let in_a = A::specs().iter().any(|s| s.key == key);
        let result = if in_a {
            self.0.set(key, value)
        } else {
            self.1.set(key, value)
        };
        result.map_err(|e| __with_keys(e, Self::keys()))
    }

    fn validate(&self) -> Result<(), OptionError> {
        self.0
            .validate()
            .and_then(|()| self.1.validate())
            .map_err(|e| __with_keys(e, Self::keys()))
    }
}

/// The specs of a group of options (`groups { .. }` in [`options!`]) with
/// the defaults its parent declares for it.
#[doc(hidden)]
pub fn __group_specs<G: Options>(parent_default: &G) -> Vec<Spec> {
    let values = parent_default.values();
    G::specs()
        .into_iter()
        .map(|mut s| {
            if let Some((_, v)) = values.iter().find(|(k, _)| *k == s.key) {
                s.default.clone_from(v);
            }
            s
        })
        .collect()
}

/// Panics (in debug builds: a declaration error, found by the first test
/// that lists the options) when two options of `name` share a key.
#[doc(hidden)]
pub fn __check_unique(name: &str, specs: &[Spec]) {
    if cfg!(debug_assertions) {
        for (i, a) in specs.iter().enumerate() {
            assert!(
                specs[..i].iter().all(|b| b.key != a.key),
                "options {name}: the key `{}` is declared twice (own fields and groups share one namespace)",
                a.key
            );
        }
    }
}

/// `e` listing `valid` as the valid keys (the tuple of two option sets and
/// `options!` groups).
#[doc(hidden)]
pub fn __with_keys(e: OptionError, valid: String) -> OptionError {
    match e {
        OptionError::UnknownKey { key, .. } => OptionError::UnknownKey { key, valid },
        OptionError::BadValue {
            key,
            value,
            expected,
            ..
        } => OptionError::BadValue {
            key,
            value,
            expected,
            valid,
        },
        other => other,
    }
}

/// Declares a struct of options and implements [`Options`] and [`Default`]
/// for it. Each field is
///
/// ```text
/// /// Documentation: what it is, where the default comes from.
/// pub NAME: TYPE = DEFAULT [, in DOMAIN] [, via CODEC];
/// ```
///
/// `DOMAIN` is a [`Domain`] of the type (`1..=100`, [`above`]`(0.0)`,
/// [`Each`]); `CODEC` a [`Codec`] for a type that is not an
/// [`OptionValue`]. After the struct, `groups { /// doc
/// pub NAME: TYPE = DEFAULT; .. }` embeds other options structs as fields
/// whose keys join this struct's (one flat namespace, no prefix: a key in
/// two places is a declaration error), each with the default this struct
/// gives it (shared parameter sets with per-user defaults). Then `check PATH;` names a
/// `fn(&Self) -> Result<(), String>` run after every [`Options::set`] and by
/// [`Options::validate`] (for rules between options). The struct must be
/// `Clone`. See the crate docs for an example.
#[macro_export]
macro_rules! options {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident {
            $(
                $(#[doc = $doc:literal])*
                $fvis:vis $field:ident : $ty:ty = $default:expr
                    $(, in $dom:expr)? $(, via $codec:ty)? ;
            )*
        }
        $(groups {
            $(
                $(#[doc = $gdoc:literal])*
                $gvis:vis $gfield:ident : $gty:ty = $gdefault:expr ;
            )*
        })?
        $(check $check:path;)?
    ) => {
        $(#[$meta])*
        $vis struct $name {
            $(
                $(#[doc = $doc])*
                $fvis $field: $ty,
            )*
            $($(
                $(#[doc = $gdoc])*
                $gvis $gfield: $gty,
            )*)?
        }

        impl ::core::default::Default for $name {
            /// Every option at its declared default.
            fn default() -> Self {
                Self {
                    $($field: $default,)*
                    $($($gfield: $gdefault,)*)?
                }
            }
        }

        impl $crate::Options for $name {
            fn specs() -> ::std::vec::Vec<$crate::Spec> {
                #[allow(unused_mut)]
                let mut specs = ::std::vec![$(
                    $crate::Spec {
                        key: stringify!($field),
                        ty: <$crate::options!(@codec $ty $(, $codec)?) as $crate::Codec<$ty>>::type_name(),
                        domain: $crate::options!(@domain $ty $(, $codec)?; $($dom)?),
                        default: <$crate::options!(@codec $ty $(, $codec)?) as $crate::Codec<$ty>>::format(&$default),
                        doc: $crate::__doc(&[$($doc),*]),
                    },
                )*];
                $($(
                    let group: $gty = $gdefault;
                    specs.extend($crate::__group_specs(&group));
                )*)?
                $crate::__check_unique(stringify!($name), &specs);
                specs
            }

            fn values(&self) -> ::std::vec::Vec<(&'static str, ::std::string::String)> {
                #[allow(unused_mut)]
                let mut values = ::std::vec![$(
                    (
                        stringify!($field),
                        <$crate::options!(@codec $ty $(, $codec)?) as $crate::Codec<$ty>>::format(&self.$field),
                    ),
                )*];
                $($(
                    values.extend($crate::Options::values(&self.$gfield));
                )*)?
                values
            }

            fn set(&mut self, key: &str, value: &str) -> ::core::result::Result<(), $crate::OptionError> {
                let bad = |expected: ::std::string::String| $crate::OptionError::BadValue {
                    key: key.to_string(),
                    value: value.to_string(),
                    expected,
                    valid: <Self as $crate::Options>::keys(),
                };
                let mut next = self.clone();
                let mut known = false;
                $(
                    if key == stringify!($field) {
                        known = true;
                        let domain = ::std::format!(
                            "expected {}",
                            $crate::options!(@domain $ty $(, $codec)?; $($dom)?)
                        );
                        let v = <$crate::options!(@codec $ty $(, $codec)?) as $crate::Codec<$ty>>::parse(value)
                            .ok_or_else(|| bad(domain.clone()))?;
                        $(
                            if !$crate::Domain::admits(&$dom, &v) {
                                return Err(bad(domain));
                            }
                        )?
                        next.$field = v;
                    }
                )*
                $($(
                    if !known && <$gty as $crate::Options>::specs().iter().any(|s| s.key == key) {
                        known = true;
                        $crate::Options::set(&mut next.$gfield, key, value)
                            .map_err(|e| $crate::__with_keys(e, <Self as $crate::Options>::keys()))?;
                    }
                )*)?
                if !known {
                    return Err($crate::OptionError::UnknownKey {
                        key: key.to_string(),
                        valid: <Self as $crate::Options>::keys(),
                    });
                }
                $( $check(&next).map_err(bad)?; )?
                *self = next;
                Ok(())
            }

            fn validate(&self) -> ::core::result::Result<(), $crate::OptionError> {
                #[allow(unused_variables)]
                let bad = |key: &str, expected: ::std::string::String| $crate::OptionError::BadValue {
                    key: key.to_string(),
                    value: <Self as $crate::Options>::get(self, key).unwrap_or_default(),
                    expected,
                    valid: <Self as $crate::Options>::keys(),
                };
                $($(
                    if !$crate::Domain::admits(&$dom, &self.$field) {
                        return Err(bad(
                            stringify!($field),
                            ::std::format!("expected {}", $crate::Domain::describe(&$dom)),
                        ));
                    }
                )?)*
                $($(
                    $crate::Options::validate(&self.$gfield)
                        .map_err(|e| $crate::__with_keys(e, <Self as $crate::Options>::keys()))?;
                )*)?
                $( $check(self).map_err(|e| bad("", e))?; )?
                Ok(())
            }
        }
    };
    (@codec $ty:ty) => { $crate::Native };
    (@codec $ty:ty, $codec:ty) => { $codec };
    (@domain $ty:ty $(, $codec:ty)?; ) => {
        <$crate::options!(@codec $ty $(, $codec)?) as $crate::Codec<$ty>>::domain()
    };
    (@domain $ty:ty $(, $codec:ty)?; $dom:expr) => { $crate::Domain::describe(&$dom) };
}

/// Implements [`OptionValue`] for a closed enum of this crate, each variant
/// by its name: `choice! { Metric { Rmse = "rmse", Mae = "mae" } }`. For an
/// enum of another crate, `choice! { pub codec NAME for ENUM { ... } }`
/// declares a [`Codec`] `NAME` to name on the field (`via NAME`).
#[macro_export]
macro_rules! choice {
    ($enum:ty { $($variant:ident = $text:literal),+ $(,)? }) => {
        impl $crate::OptionValue for $enum {
            const TYPE: &'static str = stringify!($enum);
            fn parse_option(s: &str) -> ::core::option::Option<Self> {
                match s.trim() {
                    $($text => Some(<$enum>::$variant),)+
                    _ => None,
                }
            }
            fn format_option(&self) -> ::std::string::String {
                match self {
                    $(<$enum>::$variant => $text,)+
                }
                .to_string()
            }
            fn domain() -> ::std::string::String {
                $crate::__choices(&[$($text),+])
            }
        }
    };
    ($(#[$meta:meta])* $vis:vis codec $codec:ident for $enum:ty { $($variant:ident = $text:literal),+ $(,)? }) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy)]
        $vis struct $codec;
        impl $crate::Codec<$enum> for $codec {
            fn type_name() -> &'static str {
                stringify!($enum)
            }
            fn parse(s: &str) -> ::core::option::Option<$enum> {
                match s.trim() {
                    $($text => Some(<$enum>::$variant),)+
                    _ => None,
                }
            }
            #[allow(unreachable_patterns)]
            fn format(v: &$enum) -> ::std::string::String {
                match v {
                    $(<$enum>::$variant => $text,)+
                    _ => "?",
                }
                .to_string()
            }
            fn domain() -> ::std::string::String {
                $crate::__choices(&[$($text),+])
            }
        }
    };
}

/// The doc lines of a field, each trimmed, as one text (used by
/// [`options!`]).
#[doc(hidden)]
pub fn __doc(lines: &[&str]) -> String {
    let lines: Vec<&str> = lines.iter().map(|l| l.trim()).collect();
    lines.join("\n").trim().to_string()
}

/// `a|b|c` (used by [`choice!`]).
#[doc(hidden)]
pub fn __choices(names: &[&str]) -> String {
    names.join("|")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Clone, Copy, PartialEq)]
    enum Metric {
        Rmse,
        Eq11,
    }
    choice! { Metric { Rmse = "rmse", Eq11 = "eq11" } }

    /// An enum standing for one of another crate.
    mod foreign {
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub enum Scheme {
            Residual,
            Systematic,
        }
    }
    use foreign::Scheme;
    choice! {
        /// Reads [`Scheme`] by name.
        codec SchemeName for Scheme { Residual = "residual", Systematic = "systematic" }
    }

    fn ordered(c: &All) -> Result<(), String> {
        if c.low <= c.high {
            Ok(())
        } else {
            Err("low must be at most high".into())
        }
    }

    options! {
        /// Every declared type.
        #[derive(Debug, Clone, PartialEq)]
        struct All {
            /// Runs
            /// (the paper's 100).
            runs: usize = 100, in 1..=1000;
            /// Seed.
            seed: u64 = 1;
            /// Quality.
            quality: u8 = 75, in 0..=100;
            /// A noise.
            noise: f64 = 0.1, in above(0.0);
            /// A fraction.
            fraction: f64 = 0.5, in inside(0.0, 1.0);
            /// A threshold.
            threshold: f32 = 0.25;
            /// A switch.
            on: bool = false;
            /// An error formula.
            metric: Metric = Metric::Rmse;
            /// A foreign enum.
            scheme: Scheme = Scheme::Residual, via SchemeName;
            /// Maybe a count.
            count: Option<usize> = None, in IfSome(1..=10);
            /// A list.
            speeds: Vec<f64> = vec![2.0, 3.5], in Each(0.0..=40.0);
            /// Low.
            low: f64 = 1.0;
            /// High.
            high: f64 = 2.0;
        }
        check ordered;
    }

    #[test]
    fn describe_then_set_gives_the_same_options() {
        let mut a = All::default();
        for (k, v) in [
            ("runs", "7"),
            ("seed", "18446744073709551615"),
            ("quality", "0"),
            ("noise", "0.30000000000000004"),
            ("fraction", "1e-7"),
            ("threshold", "0.1"),
            ("on", "true"),
            ("metric", "eq11"),
            ("scheme", "systematic"),
            ("count", "3"),
            ("speeds", "0,1.25,40"),
            ("low", "-1e-300"),
            ("high", "1e300"),
        ] {
            a.set(k, v).unwrap_or_else(|e| panic!("{k}={v}: {e}"));
        }
        let mut b = All::default();
        b.set_all(&a.describe()).unwrap();
        assert_eq!(a, b);
        assert_eq!(a.describe(), b.describe());
        // the defaults round-trip too, including `none`
        let mut c = a.clone();
        c.set_all(&All::default().describe()).unwrap();
        assert_eq!(c, All::default());
        assert_eq!(a.get("scheme").as_deref(), Some("systematic"));
    }

    #[test]
    fn bad_values_are_refused_and_leave_the_options_as_they_were() {
        let mut a = All::default();
        for (k, v) in [
            ("runs", "0"),
            ("runs", "1001"),
            ("runs", "-1"),
            ("runs", "1.5"),
            ("seed", "18446744073709551616"),
            ("quality", "101"),
            ("noise", "0"),
            ("noise", "inf"),
            ("noise", "NaN"),
            ("fraction", "1"),
            ("threshold", "1e39"),
            ("on", "yes"),
            ("metric", "mae"),
            ("scheme", "stratified"),
            ("count", "0"),
            ("speeds", "1,,2"),
            ("speeds", "41"),
            ("low", "3"),
        ] {
            let e = a.set(k, v).unwrap_err();
            assert!(matches!(e, OptionError::BadValue { .. }), "{k}={v}: {e}");
            assert_eq!(e.key(), k);
            assert_eq!(a, All::default(), "{k}={v}");
        }
        let e = a.set("low", "3").unwrap_err().to_string();
        assert!(e.contains("low must be at most high"), "{e}");
    }

    #[test]
    fn a_bad_key_lists_the_valid_ones() {
        let e = All::default().set("rnus", "3").unwrap_err();
        assert!(matches!(e, OptionError::UnknownKey { .. }));
        let msg = e.to_string();
        assert!(
            msg.starts_with(
                "unknown option `rnus`; valid keys: runs (1..=1000), seed (u64), \
                 quality (0..=100), noise (> 0), fraction (0 < v < 1), threshold (finite), \
                 on (true|false), metric (rmse|eq11), scheme (residual|systematic), \
                 count (none or 1..=10), speeds (comma list, each 0..=40), low (finite)"
            ),
            "{msg}"
        );
    }

    #[test]
    fn specs_carry_type_default_and_documentation() {
        let specs = All::specs();
        assert_eq!(specs.len(), 13);
        assert_eq!(
            specs[0],
            Spec {
                key: "runs",
                ty: "usize",
                domain: "1..=1000".into(),
                default: "100".into(),
                doc: "Runs\n(the paper's 100).".into(),
            }
        );
        assert_eq!((specs[7].ty, specs[8].ty), ("Metric", "Scheme"));
        assert_eq!(specs[9].default, "none");
        assert_eq!(
            specs[0].to_string(),
            "runs: usize (1..=1000) = 100\n    Runs\n    (the paper's 100)."
        );
    }

    #[test]
    fn validate_checks_options_built_in_code() {
        assert!(All::default().validate().is_ok());
        let a = All {
            runs: 0,
            ..All::default()
        };
        assert_eq!(a.validate().unwrap_err().key(), "runs");
        let b = All {
            low: 5.0,
            ..All::default()
        };
        assert!(b.validate().is_err());
        assert!(matches!(
            All::default().set_all("runs"),
            Err(OptionError::NotKeyValue { .. })
        ));
    }

    options! {
        /// A tracker's own option.
        #[derive(Debug, Clone, PartialEq)]
        struct Count {
            /// Particles.
            particles: usize = 30, in 1..=100;
        }
    }

    #[test]
    fn a_pair_of_groups_is_one_set_of_options() {
        let mut p = (Count::default(), All::default());
        let keys: Vec<&str> = <(Count, All)>::specs().iter().map(|s| s.key).collect();
        assert_eq!(keys[..2], ["particles", "runs"]);
        p.set("particles", "70").unwrap();
        p.set("runs", "5").unwrap();
        assert_eq!((p.0.particles, p.1.runs), (70, 5));
        // an error in either group carries the keys of both; an unknown
        // key's message lists them, a bad value's names its own domain
        for (k, v) in [("particles", "0"), ("runs", "0"), ("typo", "1")] {
            let e = p.set(k, v).unwrap_err();
            let (OptionError::UnknownKey { valid, .. } | OptionError::BadValue { valid, .. }) = &e
            else {
                panic!("{e:?}")
            };
            assert!(
                valid.contains("particles (1..=100)") && valid.contains("runs (1..=1000)"),
                "{valid}"
            );
        }
        let e = p.set("typo", "1").unwrap_err().to_string();
        assert!(
            e.contains("particles (1..=100)") && e.contains("runs (1..=1000)"),
            "{e}"
        );
        let e = p.set("runs", "0").unwrap_err().to_string();
        assert_eq!(e, "bad value `0` for `runs`: expected 1..=1000");
        assert_eq!(p.0.particles, 70, "a refused value changes nothing");
        let mut q = (Count::default(), All::default());
        q.set_all(&p.describe()).unwrap();
        assert_eq!(p, q);
    }

    options! {
        /// A parameter set shared by two structs.
        #[derive(Debug, Clone, PartialEq)]
        struct Shared {
            /// A rate.
            rate: f64 = 0.5, in inside(0.0, 1.0);
            /// A switch.
            on: bool = true;
        }
        check shared_check;
    }

    fn shared_check(c: &Shared) -> Result<(), String> {
        if c.on || c.rate == 0.5 {
            Ok(())
        } else {
            Err("rate is unused when off: leave it at 0.5".into())
        }
    }

    options! {
        /// Own fields, then a group with its own default.
        #[derive(Debug, Clone, PartialEq)]
        struct Outer {
            /// A count.
            count: usize = 3, in 1..=10;
        }
        groups {
            /// The shared set, at this struct's rate.
            shared: Shared = Shared { rate: 0.25, ..Shared::default() };
        }
        check outer_check;
    }

    fn outer_check(c: &Outer) -> Result<(), String> {
        if c.count > 5 && c.shared.rate > 0.5 {
            Err("count above 5 needs rate at most 0.5".into())
        } else {
            Ok(())
        }
    }

    #[test]
    fn groups_join_the_namespace_with_the_parents_defaults() {
        let mut o = Outer::default();
        assert_eq!(o.shared.rate, 0.25);
        let specs = Outer::specs();
        let keys: Vec<_> = specs.iter().map(|s| s.key).collect();
        assert_eq!(keys, ["count", "rate", "on"]);
        // the listing shows the parent's default for the group, not the
        // group's own
        assert_eq!(specs[1].default, "0.25");
        assert_eq!(o.describe(), "count=3 rate=0.25 on=true");
        o.set("rate", "0.75").unwrap();
        assert_eq!(o.shared.rate, 0.75);
        // the group's domain, the group's check, the parent's check: each
        // refuses and leaves the options as they were
        let e = o.set("rate", "2").unwrap_err().to_string();
        assert_eq!(e, "bad value `2` for `rate`: expected 0 < v < 1");
        let e = o.set("on", "false").unwrap_err().to_string();
        assert!(e.contains("unused when off"), "{e}");
        let e = o.set("count", "7").unwrap_err().to_string();
        assert!(e.contains("needs rate at most 0.5"), "{e}");
        assert_eq!(o.describe(), "count=3 rate=0.75 on=true");
        // an unknown key lists the group's keys too
        let e = o.set("rat", "1").unwrap_err();
        let OptionError::UnknownKey { valid, .. } = &e else {
            panic!("{e:?}")
        };
        assert!(valid.contains("rate (0 < v < 1)") && valid.contains("count (1..=10)"));
        // a group error lists the parent's keys
        let OptionError::BadValue { valid, .. } = o.set("rate", "2").unwrap_err() else {
            panic!()
        };
        assert!(valid.contains("count (1..=10)"), "{valid}");
        // validate reaches into the group
        let mut bad = Outer::default();
        bad.shared.rate = 3.0;
        assert_eq!(bad.validate().unwrap_err().key(), "rate");
        // describe -> set_all round trip
        let mut p = Outer::default();
        p.set_all(&o.describe()).unwrap();
        assert_eq!(p, o);
    }

    options! {
        /// A key in its own fields and in a group.
        #[derive(Debug, Clone, PartialEq)]
        struct Twice {
            /// Clashes with the group's.
            rate: f64 = 0.1;
        }
        groups {
            /// The shared set.
            shared: Shared = Shared::default();
        }
    }

    #[test]
    #[should_panic(expected = "the key `rate` is declared twice")]
    fn a_key_in_a_group_and_the_struct_is_a_declaration_error() {
        let _ = Twice::specs();
    }
}
