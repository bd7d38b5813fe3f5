//! Lists of numbers on the command line, one syntax for every command: `a,b,c`, or an
//! inclusive range `a..b` (`--seeds 1..10`, `--particles 25,50,100`).

use std::ops::AddAssign;
use std::str::FromStr;

/// A non-empty list of numbers, written `a,b,c` or `a..b` (inclusive); in JSON, an array.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(transparent)]
pub struct List<T>(pub Vec<T>);

impl<T> FromStr for List<T>
where
    T: FromStr + Copy + PartialOrd + AddAssign + From<u8>,
    T::Err: std::fmt::Display,
{
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        let number = |s: &str| s.trim().parse::<T>().map_err(|e| format!("`{s}`: {e}"));
        let values: Vec<T> = match text.split_once("..") {
            Some((a, b)) => {
                let (mut next, last) = (number(a)?, number(b)?);
                let mut values = Vec::new();
                while next <= last {
                    values.push(next);
                    next += T::from(1);
                }
                values
            }
            None => text.split(',').map(number).collect::<Result<_, _>>()?,
        };
        if values.is_empty() {
            return Err(format!("`{text}` holds no number"));
        }
        Ok(Self(values))
    }
}

impl<T> List<T> {
    /// The numbers, in order.
    pub fn values(&self) -> &[T] {
        &self.0
    }
}

impl<T> std::ops::Deref for List<T> {
    type Target = [T];

    fn deref(&self) -> &[T] {
        &self.0
    }
}

impl<'a, T> IntoIterator for &'a List<T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;

    fn into_iter(self) -> Self::IntoIter {
        self.0.iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_are_an_inclusive_range_or_comma_separated() {
        assert_eq!("1..3".parse::<List<u64>>().unwrap().0, [1, 2, 3]);
        assert_eq!("4, 7".parse::<List<u64>>().unwrap().0, [4, 7]);
        assert_eq!("25,50".parse::<List<usize>>().unwrap().0, [25, 50]);
        assert_eq!("5..5".parse::<List<usize>>().unwrap().0, [5]);
        assert!("3..1".parse::<List<u64>>().is_err());
        assert!("x".parse::<List<u64>>().is_err());
        assert!("1,,2".parse::<List<u64>>().is_err());
    }
}
