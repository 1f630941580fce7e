//! Reading one sweep table of a plan: typed, checked values with the span they came from.
//!
//! A key's value is a scalar, a list of scalars, or a range `{ from, to, step }` (step 1 by
//! default, `to` included). Every value is checked where it was written, so an error points at
//! the list element or range that is wrong, not just at the key.

use std::ops::Range;

use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// A range may not expand to more values than this: a typo in `step` must not allocate gigabytes.
pub(crate) const MAX_RANGE_VALUES: u64 = 100_000;

/// A plan error before it is given a file, line and column.
#[derive(Debug)]
pub(crate) struct Issue {
    pub span: Range<usize>,
    pub key: Option<String>,
    pub message: String,
}

impl Issue {
    pub fn new(span: Range<usize>, key: Option<&str>, message: impl Into<String>) -> Self {
        Self {
            span,
            key: key.map(str::to_owned),
            message: message.into(),
        }
    }
}

/// A value as TOML, with the span it was written at.
pub(crate) type Written = (Range<usize>, toml::Value);

/// A check on one value: `Err` holds the reason, e.g. "must be positive, got -1".
pub(crate) type Check<'c, T> = &'c dyn Fn(T) -> Result<(), String>;

/// One `[[kind]]` table whose keys have been checked against the kind's known keys.
pub(crate) struct Sweep<'a, 'i> {
    header: Range<usize>,
    table: &'a DeTable<'i>,
}

impl<'a, 'i> Sweep<'a, 'i> {
    /// Rejects the first unknown key (in file order); `known` lists the keys of `what` (e.g.
    /// `[[overlap]]`).
    pub fn new(
        what: &str,
        header: Range<usize>,
        table: &'a DeTable<'i>,
        known: &[&str],
    ) -> Result<Self, Issue> {
        let mut unknown: Vec<&Spanned<toml::de::DeString<'i>>> = table
            .keys()
            .filter(|k| !known.contains(&k.get_ref().as_ref()))
            .collect();
        unknown.sort_by_key(|k| k.span().start);
        if let Some(key) = unknown.first() {
            return Err(Issue::new(
                key.span(),
                Some(key.get_ref()),
                format!(
                    "unknown key in {what} (expected one of {})",
                    known.join(", ")
                ),
            ));
        }
        Ok(Self { header, table })
    }

    pub fn header(&self) -> Range<usize> {
        self.header.clone()
    }

    fn get(&self, key: &str) -> Option<&'a Spanned<DeValue<'i>>> {
        self.table.get(key)
    }

    /// Where `key` was written, or the table header when it was left to its default.
    pub fn span_of(&self, key: &str) -> Range<usize> {
        self.get(key).map_or_else(|| self.header(), Spanned::span)
    }

    fn missing(&self, key: &str) -> Issue {
        Issue::new(
            self.header(),
            Some(key),
            "missing (this key has no default)",
        )
    }

    /// An expandable real-valued key.
    pub fn floats(
        &self,
        key: &str,
        default: Option<f64>,
        check: Check<'_, f64>,
    ) -> Result<Vec<f64>, Issue> {
        let Some(value) = self.get(key) else {
            return default.map(|d| vec![d]).ok_or_else(|| self.missing(key));
        };
        let fail = |span: Range<usize>, message: String| Issue::new(span, Some(key), message);
        let mut out = Vec::new();
        for (span, item) in items(value, key)? {
            match item {
                Item::Scalar(v) => {
                    let x = real(v).map_err(|m| fail(span.clone(), m))?;
                    check(x).map_err(|m| fail(span, m))?;
                    out.push(x);
                }
                Item::Range(table) => {
                    for x in float_range(table, span.clone(), key)? {
                        check(x).map_err(|m| fail(span.clone(), m))?;
                        out.push(x);
                    }
                }
            }
        }
        Ok(out)
    }

    /// An expandable real-valued key without a default: `[None]` when absent, so that a point
    /// that does not set it keeps the identity it had before the key existed.
    pub fn optional_floats(
        &self,
        key: &str,
        check: Check<'_, f64>,
    ) -> Result<Vec<Option<f64>>, Issue> {
        if self.get(key).is_none() {
            return Ok(vec![None]);
        }
        Ok(self
            .floats(key, None, check)?
            .into_iter()
            .map(Some)
            .collect())
    }

    /// An expandable integer key without a default, as [`Sweep::optional_floats`].
    pub fn optional_integers(
        &self,
        key: &str,
        check: Check<'_, u64>,
    ) -> Result<Vec<Option<u64>>, Issue> {
        if self.get(key).is_none() {
            return Ok(vec![None]);
        }
        Ok(self
            .integers(key, None, check)?
            .into_iter()
            .map(Some)
            .collect())
    }

    /// An expandable non-negative integer key.
    pub fn integers(
        &self,
        key: &str,
        default: Option<u64>,
        check: Check<'_, u64>,
    ) -> Result<Vec<u64>, Issue> {
        let Some(value) = self.get(key) else {
            return default.map(|d| vec![d]).ok_or_else(|| self.missing(key));
        };
        let fail = |span: Range<usize>, message: String| Issue::new(span, Some(key), message);
        let mut out = Vec::new();
        for (span, item) in items(value, key)? {
            match item {
                Item::Scalar(v) => {
                    let n = whole(v).map_err(|m| fail(span.clone(), m))?;
                    check(n).map_err(|m| fail(span, m))?;
                    out.push(n);
                }
                Item::Range(table) => {
                    for n in integer_range(table, span.clone(), key)? {
                        check(n).map_err(|m| fail(span.clone(), m))?;
                        out.push(n);
                    }
                }
            }
        }
        Ok(out)
    }

    /// An expandable key of any scalar type, as TOML values, each with the span it was written
    /// at: for kinds whose keys and checks are defined elsewhere (the `edmd` crate's scenes). A
    /// range gives integers when `from`, `to` and `step` are all integers, else reals (all at the
    /// range's span). `None` when the key is absent.
    pub fn values(&self, key: &str) -> Result<Option<Vec<Written>>, Issue> {
        let Some(value) = self.get(key) else {
            return Ok(None);
        };
        let fail = |span: Range<usize>, message: String| Issue::new(span, Some(key), message);
        let mut out = Vec::new();
        for (span, item) in items(value, key)? {
            match item {
                Item::Scalar(v) => out.push((span.clone(), scalar_value(v, span, key)?)),
                Item::Range(table) => {
                    if table
                        .values()
                        .all(|v| matches!(v.get_ref(), DeValue::Integer(_)))
                    {
                        for n in integer_range(table, span.clone(), key)? {
                            let n = i64::try_from(n)
                                .map_err(|_| fail(span.clone(), format!("{n} is out of range")))?;
                            out.push((span.clone(), toml::Value::Integer(n)));
                        }
                    } else {
                        out.extend(
                            float_range(table, span.clone(), key)?
                                .into_iter()
                                .map(|x| (span.clone(), toml::Value::Float(x))),
                        );
                    }
                }
            }
        }
        Ok(Some(out))
    }

    /// An expandable key whose every value is itself a list of scalars or of tables of scalars
    /// and lists of scalars (a scene's `exponents = [n, m, p]`, its `[[edmd.species]]`): such a
    /// list is one value, a list of such lists is a sweep
    /// over them, each with the span it was written at. Ranges and deeper nesting are refused;
    /// the element types and the list's length are the defining crate's to check. `None` when
    /// the key is absent.
    pub fn lists(&self, key: &str) -> Result<Option<Vec<Written>>, Issue> {
        let Some(value) = self.get(key) else {
            return Ok(None);
        };
        let fail = |span: Range<usize>, message: &str| Issue::new(span, Some(key), message);
        let list = |span: Range<usize>, elements: &[Spanned<DeValue<'i>>]| {
            if elements.is_empty() {
                return Err(fail(span, "must not be an empty list"));
            }
            let values = elements
                .iter()
                .map(|e| match e.get_ref() {
                    // A list of tables (a scene's `[[edmd.species]]`): each table one element.
                    DeValue::Table(t) => table_value(t, key),
                    DeValue::Array(_) => Err(fail(
                        e.span(),
                        "a list of lists is a sweep; a list inside one of its lists is not allowed",
                    )),
                    scalar => scalar_value(scalar, e.span(), key),
                })
                .collect::<Result<Vec<_>, _>>()?;
            Ok((span, toml::Value::Array(values)))
        };
        let DeValue::Array(outer) = value.get_ref() else {
            let what = value.get_ref().type_str();
            let message = if matches!(value.get_ref(), DeValue::Table(_)) {
                "takes a list as its value (or a list of lists, to sweep); a range cannot give one"
                    .to_owned()
            } else {
                format!("takes a list as its value (or a list of lists, to sweep), got {what}")
            };
            return Err(Issue::new(value.span(), Some(key), message));
        };
        let nested = |e: &Spanned<DeValue<'_>>| matches!(e.get_ref(), DeValue::Array(_));
        let sweep = outer.first().is_some_and(nested);
        if let Some(odd) = outer.iter().find(|e| nested(e) != sweep) {
            return Err(fail(
                odd.span(),
                "mixes lists and single values: write one list, or a list of lists to sweep",
            ));
        }
        if !sweep {
            return Ok(Some(vec![list(value.span(), outer)?]));
        }
        outer
            .iter()
            .filter_map(|element| match element.get_ref() {
                DeValue::Array(inner) => Some(list(element.span(), inner)),
                _ => None, // none: every element is a list, checked above
            })
            .collect::<Result<Vec<_>, _>>()
            .map(Some)
    }

    /// A non-negative integer key that takes one value (no list, no range).
    pub fn integer(
        &self,
        key: &str,
        default: Option<u64>,
        check: Check<'_, u64>,
    ) -> Result<u64, Issue> {
        let Some(value) = self.get(key) else {
            return default.ok_or_else(|| self.missing(key));
        };
        if let DeValue::Array(_) | DeValue::Table(_) = value.get_ref() {
            let what = value.get_ref().type_str();
            return Err(Issue::new(
                value.span(),
                Some(key),
                format!("expected one whole number (no list or range), got {what}"),
            ));
        }
        let n = whole(value.get_ref()).map_err(|m| Issue::new(value.span(), Some(key), m))?;
        check(n).map_err(|m| Issue::new(value.span(), Some(key), m))?;
        Ok(n)
    }

    /// An expandable key whose values are names (e.g. `precision`).
    pub fn names<T>(
        &self,
        key: &str,
        default: T,
        parse: &dyn Fn(&str) -> Result<T, String>,
    ) -> Result<Vec<T>, Issue> {
        let Some(value) = self.get(key) else {
            return Ok(vec![default]);
        };
        let mut out = Vec::new();
        for (span, item) in items(value, key)? {
            let Item::Scalar(DeValue::String(s)) = item else {
                return Err(Issue::new(
                    span,
                    Some(key),
                    "expected a string or a list of strings",
                ));
            };
            out.push(parse(s).map_err(|m| Issue::new(span, Some(key), m))?);
        }
        Ok(out)
    }

    /// A key whose value is one set of names (e.g. `algorithms`): a list is not expanded, a
    /// repeated name is an error, and the set is returned in `T`'s order so that the order it was
    /// written in does not change a point's identity.
    pub fn name_set<T: Ord>(
        &self,
        key: &str,
        default: Vec<T>,
        parse: &dyn Fn(&str) -> Result<T, String>,
    ) -> Result<Vec<T>, Issue> {
        let Some(value) = self.get(key) else {
            return Ok(default);
        };
        let elements: Vec<&Spanned<DeValue<'i>>> = match value.get_ref() {
            DeValue::String(_) => vec![value],
            DeValue::Array(array) => array.iter().collect(),
            other => {
                return Err(Issue::new(
                    value.span(),
                    Some(key),
                    format!("expected a list of strings, got {}", other.type_str()),
                ));
            }
        };
        if elements.is_empty() {
            return Err(Issue::new(
                value.span(),
                Some(key),
                "must not be an empty list",
            ));
        }
        let mut out: Vec<T> = Vec::with_capacity(elements.len());
        for element in elements {
            let DeValue::String(s) = element.get_ref() else {
                return Err(Issue::new(element.span(), Some(key), "expected a string"));
            };
            let name = parse(s).map_err(|m| Issue::new(element.span(), Some(key), m))?;
            if out.contains(&name) {
                return Err(Issue::new(
                    element.span(),
                    Some(key),
                    format!("`{s}` is listed twice"),
                ));
            }
            out.push(name);
        }
        out.sort();
        Ok(out)
    }
}

/// One written value of a key before it is typed.
enum Item<'a, 'i> {
    Scalar(&'a DeValue<'i>),
    Range(&'a DeTable<'i>),
}

/// The values a key was given: its scalar, each element of its list, or its range.
fn items<'a, 'i>(
    value: &'a Spanned<DeValue<'i>>,
    key: &str,
) -> Result<Vec<(Range<usize>, Item<'a, 'i>)>, Issue> {
    match value.get_ref() {
        DeValue::Array(array) => {
            if array.is_empty() {
                return Err(Issue::new(
                    value.span(),
                    Some(key),
                    "must not be an empty list",
                ));
            }
            array
                .iter()
                .map(|element| match element.get_ref() {
                    DeValue::Array(_) | DeValue::Table(_) => Err(Issue::new(
                        element.span(),
                        Some(key),
                        "a list element must be a single value (no nested lists or ranges)",
                    )),
                    scalar => Ok((element.span(), Item::Scalar(scalar))),
                })
                .collect()
        }
        DeValue::Table(table) => Ok(vec![(value.span(), Item::Range(table))]),
        scalar => Ok(vec![(value.span(), Item::Scalar(scalar))]),
    }
}

/// An integer written in TOML (any radix), if it is one.
fn toml_integer(value: &DeValue<'_>) -> Option<Result<i128, String>> {
    let DeValue::Integer(i) = value else {
        return None;
    };
    Some(
        i128::from_str_radix(i.as_str(), i.radix())
            .map_err(|_| format!("integer {i} is out of range")),
    )
}

/// One scalar as a TOML value, for keys whose types are checked elsewhere.
/// A table of scalars (one element of a list of tables), its keys and types left to the defining
/// crate to check.
/// A table of scalars and lists of scalars (a species' `exponents = [n, m, p]`).
fn table_value(table: &DeTable<'_>, key: &str) -> Result<toml::Value, Issue> {
    table
        .iter()
        .map(|(k, v)| {
            let value = match v.get_ref() {
                DeValue::Array(items) => toml::Value::Array(
                    items
                        .iter()
                        .map(|e| scalar_value(e.get_ref(), e.span(), key))
                        .collect::<Result<_, _>>()?,
                ),
                scalar => scalar_value(scalar, v.span(), key)?,
            };
            Ok((k.get_ref().to_string(), value))
        })
        .collect::<Result<toml::Table, Issue>>()
        .map(toml::Value::Table)
}

fn scalar_value(value: &DeValue<'_>, span: Range<usize>, key: &str) -> Result<toml::Value, Issue> {
    let fail = |message: String| Issue::new(span.clone(), Some(key), message);
    match (value, toml_integer(value)) {
        (_, Some(n)) => {
            let n = n.map_err(&fail)?;
            i64::try_from(n)
                .map(toml::Value::Integer)
                .map_err(|_| fail(format!("{n} is out of range")))
        }
        (DeValue::String(s), None) => Ok(toml::Value::String(s.to_string())),
        (DeValue::Boolean(b), None) => Ok(toml::Value::Boolean(*b)),
        (DeValue::Float(_), None) => real(value).map(toml::Value::Float).map_err(&fail),
        (other, None) => Err(fail(format!(
            "expected a single value, got {}",
            other.type_str()
        ))),
    }
}

/// A real number: a TOML integer or a finite float.
fn real(value: &DeValue<'_>) -> Result<f64, String> {
    if let Some(i) = toml_integer(value) {
        return Ok(i? as f64);
    }
    match value {
        DeValue::Float(f) => match f.as_str().parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            _ => Err(format!("must be a finite number, got {f}")),
        },
        other => Err(format!("expected a number, got {}", other.type_str())),
    }
}

/// A non-negative whole number: a TOML integer, or a float with no fractional part (`2e6`).
fn whole(value: &DeValue<'_>) -> Result<u64, String> {
    let n: i128 = match toml_integer(value) {
        Some(i) => i?,
        None => {
            let x = real(value)
                .map_err(|_| format!("expected a whole number, got {}", value.type_str()))?;
            if x.fract() != 0.0 || x.abs() >= 2f64.powi(63) {
                return Err(format!("must be a whole number, got {x}"));
            }
            x as i128
        }
    };
    u64::try_from(n).map_err(|_| format!("must not be negative, got {n}"))
}

/// Rounds to 12 significant digits, so that `from + k·step` lands on the decimal the user meant
/// (0.1 + 2·0.1 is 0.30000000000000004 in binary; the point is 0.3).
pub(crate) fn round_to_12_digits(x: f64) -> f64 {
    format!("{x:.11e}").parse().unwrap_or(x)
}

/// The `from`, `to` and optional `step` entries of a range, each with its span.
struct RangeKeys<'a, 'i> {
    from: &'a Spanned<DeValue<'i>>,
    to: &'a Spanned<DeValue<'i>>,
    step: Option<&'a Spanned<DeValue<'i>>>,
}

fn range_keys<'a, 'i>(
    table: &'a DeTable<'i>,
    span: Range<usize>,
    key: &str,
) -> Result<RangeKeys<'a, 'i>, Issue> {
    if let Some(unknown) = table
        .keys()
        .find(|k| !["from", "to", "step"].contains(&k.get_ref().as_ref()))
    {
        return Err(Issue::new(
            unknown.span(),
            Some(key),
            format!(
                "unknown range key `{}` (a range is {{ from, to, step }})",
                unknown.get_ref()
            ),
        ));
    }
    let need = |name: &str| {
        table
            .get(name)
            .ok_or_else(|| Issue::new(span.clone(), Some(key), format!("range has no `{name}`")))
    };
    Ok(RangeKeys {
        from: need("from")?,
        to: need("to")?,
        step: table.get("step"),
    })
}

/// `from + k·step` for k = 0, 1, … while ≤ `to`, each rounded to 12 significant digits.
fn float_range(table: &DeTable<'_>, span: Range<usize>, key: &str) -> Result<Vec<f64>, Issue> {
    let keys = range_keys(table, span.clone(), key)?;
    let at = |v: &Spanned<DeValue<'_>>| {
        real(v.get_ref()).map_err(|m| Issue::new(v.span(), Some(key), m))
    };
    let (from, to) = (at(keys.from)?, at(keys.to)?);
    let step = keys.step.map(at).transpose()?.unwrap_or(1.0);
    check_range_shape(&keys, key, step > 0.0, to < from, (from, to, step))?;
    // A relative tolerance keeps `to` in when (to − from)/step is an integer up to rounding.
    let intervals = ((to - from) / step * (1.0 + 1e-12)).floor();
    if intervals >= MAX_RANGE_VALUES as f64 {
        return Err(too_many(span, key, intervals));
    }
    Ok((0..=intervals as u64)
        .map(|k| round_to_12_digits(from + k as f64 * step))
        .collect())
}

/// The same for whole numbers, in exact integer arithmetic.
fn integer_range(table: &DeTable<'_>, span: Range<usize>, key: &str) -> Result<Vec<u64>, Issue> {
    let keys = range_keys(table, span.clone(), key)?;
    let at = |v: &Spanned<DeValue<'_>>| {
        whole(v.get_ref()).map_err(|m| Issue::new(v.span(), Some(key), m))
    };
    let (from, to) = (at(keys.from)?, at(keys.to)?);
    let step = keys.step.map(at).transpose()?.unwrap_or(1);
    check_range_shape(&keys, key, step > 0, to < from, (from, to, step))?;
    let intervals = (to - from) / step;
    if intervals >= MAX_RANGE_VALUES {
        return Err(too_many(span, key, intervals as f64));
    }
    Ok((0..=intervals).map(|k| from + k * step).collect())
}

/// Rejects a non-positive step or a `to` below `from` (compared in the key's own type).
fn check_range_shape<T: std::fmt::Display>(
    keys: &RangeKeys<'_, '_>,
    key: &str,
    step_positive: bool,
    to_below_from: bool,
    (from, to, step): (T, T, T),
) -> Result<(), Issue> {
    if let Some(s) = keys.step.filter(|_| !step_positive) {
        return Err(Issue::new(
            s.span(),
            Some(key),
            format!("range `step` must be positive, got {step}"),
        ));
    }
    if to_below_from {
        return Err(Issue::new(
            keys.to.span(),
            Some(key),
            format!("range `to` ({to}) is below `from` ({from})"),
        ));
    }
    Ok(())
}

fn too_many(span: Range<usize>, key: &str, intervals: f64) -> Issue {
    Issue::new(
        span,
        Some(key),
        format!(
            "range has {} values, more than {MAX_RANGE_VALUES}",
            intervals + 1.0
        ),
    )
}

/// All index tuples of a cartesian product whose axes have `lens` values, the first axis
/// varying slowest. Every length must be at least 1 (an empty list is rejected earlier).
pub(crate) fn cartesian(lens: &[usize]) -> impl Iterator<Item = Vec<usize>> + '_ {
    let total: usize = lens.iter().product();
    (0..total).map(move |mut flat| {
        let mut index = vec![0; lens.len()];
        for (slot, &len) in index.iter_mut().zip(lens).rev() {
            *slot = flat % len;
            flat /= len;
        }
        index
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_removes_binary_noise() {
        assert_eq!(round_to_12_digits(0.1 + 2.0 * 0.1), 0.3);
        assert_eq!(round_to_12_digits(0.05), 0.05);
        assert_eq!(round_to_12_digits(20.0), 20.0);
    }

    #[test]
    fn cartesian_first_axis_slowest() {
        let all: Vec<Vec<usize>> = cartesian(&[2, 3]).collect();
        assert_eq!(all.len(), 6);
        assert_eq!(all[0], [0, 0]);
        assert_eq!(all[1], [0, 1]);
        assert_eq!(all[5], [1, 2]);
    }
}
