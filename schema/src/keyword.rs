//! Closed sets of keywords (`"path"`, `"sobol"`, …) as scene files and the command line spell
//! them, so that every front end parses into the scene's own enums instead of keeping copies.

use crate::scene::{Integrator, SamplerKind};

/// An enum whose values are written as fixed keywords.
pub trait Keyword: Sized + Copy + PartialEq + 'static {
    /// Every value with its keyword, in documentation order.
    const ALL: &'static [(&'static str, Self)];

    /// The keyword of a value.
    fn keyword(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(_, v)| *v == self)
            .map_or("", |(k, _)| k)
    }

    /// The value of a keyword; the error lists the keywords accepted.
    fn from_keyword(text: &str) -> Result<Self, UnknownKeyword> {
        Self::ALL
            .iter()
            .find(|(k, _)| *k == text)
            .map(|(_, v)| *v)
            .ok_or_else(|| UnknownKeyword {
                found: text.to_string(),
                expected: Self::ALL.iter().map(|(k, _)| *k).collect(),
            })
    }

    /// The keywords, in documentation order.
    fn keywords() -> Vec<&'static str> {
        Self::ALL.iter().map(|(k, _)| *k).collect()
    }
}

/// A word that is not one of an enum's keywords.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{found}` is not one of {}", expected.join(", "))]
pub struct UnknownKeyword {
    /// The text given.
    pub found: String,
    /// The keywords accepted.
    pub expected: Vec<&'static str>,
}

/// Implements [`Keyword`], `FromStr` and `Display` for an enum from its keyword list:
/// `keyword_enum!(Integrator, "path" => Integrator::Path, "raycast" => Integrator::Raycast);`
#[macro_export]
macro_rules! keyword_enum {
    ($ty:ty, $($word:literal => $value:expr),+ $(,)?) => {
        impl $crate::Keyword for $ty {
            const ALL: &'static [(&'static str, Self)] = &[$(($word, $value)),+];
        }
        impl std::str::FromStr for $ty {
            type Err = $crate::UnknownKeyword;
            fn from_str(text: &str) -> Result<Self, $crate::UnknownKeyword> {
                <Self as $crate::Keyword>::from_keyword(text)
            }
        }
        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str($crate::Keyword::keyword(*self))
            }
        }
    };
}

keyword_enum!(Integrator, "path" => Integrator::Path, "raycast" => Integrator::Raycast);
keyword_enum!(SamplerKind, "sobol" => SamplerKind::Sobol, "independent" => SamplerKind::Independent);

#[cfg(test)]
mod tests {
    use super::*;

    /// The keywords are exactly the scene file's spelling (serde's), so a command-line value
    /// and a scene value mean the same thing.
    #[test]
    fn keywords_match_the_scene_files_spelling() {
        fn check<T: Keyword + serde::Serialize + std::fmt::Debug>() {
            for &(word, value) in T::ALL {
                assert_eq!(serde_json::to_value(value).unwrap(), word);
                assert_eq!(T::from_keyword(word).unwrap(), value);
                assert_eq!(value.keyword(), word);
            }
        }
        check::<Integrator>();
        check::<SamplerKind>();
        let e = Integrator::from_keyword("bdpt").unwrap_err();
        assert_eq!(e.to_string(), "`bdpt` is not one of path, raycast");
    }
}
