//! Fixed-length arrays that must be written with exactly their length.
//!
//! serde's own `[T; N]` reads the first N elements and ignores the rest, and the `toml` crate
//! does not check either: `position = [0, 0, 0.2, nan]` was read as `[0, 0, 0.2]` (the NaN past
//! the NaN check), `ambient = [0.1, 0.1, 0.1, "x", true]` as three numbers. Every
//! fixed-length array of a scene or medium names one of these in `deserialize_with`:
//!
//! ```ignore
//! #[serde(deserialize_with = "exact")]
//! pub position: [f32; 3],
//! #[serde(default, deserialize_with = "exact_opt")]
//! pub falloff: Option<[f32; 3]>,
//! ```

use std::fmt;
use std::marker::PhantomData;

use serde::de::{Deserialize, Deserializer, Error, IgnoredAny, SeqAccess, Visitor};

struct Exact<T, const N: usize>(PhantomData<T>);

impl<'de, T: Deserialize<'de>, const N: usize> Visitor<'de> for Exact<T, N> {
    type Value = [T; N];

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "an array of exactly {N} elements")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<[T; N], A::Error> {
        let mut items = Vec::with_capacity(N);
        while items.len() < N {
            match seq.next_element()? {
                Some(x) => items.push(x),
                None => return Err(A::Error::invalid_length(items.len(), &self)),
            }
        }
        // Count what is left (of any type) for the message, without keeping it.
        let mut extra = 0usize;
        while seq.next_element::<IgnoredAny>()?.is_some() {
            extra += 1;
        }
        if extra > 0 {
            return Err(A::Error::invalid_length(N + extra, &self));
        }
        Ok(items
            .try_into()
            .unwrap_or_else(|_| unreachable!("exactly N elements were pushed")))
    }
}

/// `[T; N]` from a sequence of exactly N elements: fewer or more is an "invalid length" error.
pub fn exact<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    d.deserialize_tuple(N, Exact::<T, N>(PhantomData))
}

/// [`exact`] for an optional array (give the field `#[serde(default)]` as well, so that a
/// missing key is `None`).
pub fn exact_opt<'de, D, T, const N: usize>(d: D) -> Result<Option<[T; N]>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    exact(d).map(Some)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, serde::Deserialize)]
    struct S {
        #[serde(deserialize_with = "exact")]
        v: [f32; 3],
        #[serde(default, deserialize_with = "exact_opt")]
        o: Option<[bool; 2]>,
    }

    fn parse(s: &str) -> Result<S, String> {
        serde_json::from_str(s).map_err(|e| e.to_string())
    }

    #[test]
    fn exactly_n_elements_and_no_more() {
        let s = parse(r#"{"v": [1, 2, 3]}"#).unwrap();
        assert_eq!((s.v, s.o), ([1.0, 2.0, 3.0], None));
        assert_eq!(
            parse(r#"{"v": [1, 2, 3], "o": [true, false]}"#).unwrap().o,
            Some([true, false])
        );
        let e = parse(r#"{"v": [1, 2, 3, "x", true]}"#).unwrap_err();
        assert!(
            e.contains("invalid length 5, expected an array of exactly 3 elements"),
            "{e}"
        );
        let e = parse(r#"{"v": [1, 2]}"#).unwrap_err();
        assert!(e.contains("invalid length 2"), "{e}");
        let e = parse(r#"{"v": [1, 2, 3], "o": [true, false, true]}"#).unwrap_err();
        assert!(e.contains("invalid length 3"), "{e}");
    }
}
