//! `[[command]]` sweeps: a program, its arguments with `{key}` placeholders, and every other key
//! a parameter swept as in the other families.
//!
//! The program is resolved against the plan file's folder, must be an executable file, and is
//! hashed (BLAKE3) here, once per sweep: the hash is part of every point's identity.
//! `[command.values]` regexes are compiled here and must have exactly one capture group.

use std::collections::BTreeMap;
use std::ops::Range;
use std::os::unix::fs::PermissionsExt;
use std::path::Path;

use serde_json::Value;
use toml::de::{DeTable, DeValue};

use crate::command::{CommandSpec, hash_file};
use crate::plan::{Defaults, MAX_TIME_CAP_S, check_product};
use crate::spec::JobSpec;
use crate::sweep::{Issue, Sweep, Written, cartesian};

/// Keys of a `[[command]]` table that are not parameters.
const RESERVED: [&str; 5] = ["label", "program", "args", "timeout_s", "values"];

pub(crate) fn expand_command(
    header: Range<usize>,
    table: &DeTable<'_>,
    defaults: &Defaults,
) -> Result<Vec<JobSpec>, Issue> {
    // Every key is allowed: those not reserved are parameters.
    let keys: Vec<String> = table.keys().map(|k| k.get_ref().to_string()).collect();
    let known: Vec<&str> = keys.iter().map(String::as_str).collect();
    let sweep = &Sweep::new("[[command]]", header.clone(), table, &known)?;

    let label = string_key(table, "label", &header)?;
    let program_text = string_key(table, "program", &header)?;
    let program_span = sweep.span_of("program");
    let program = defaults.dir.join(&program_text);
    let program = program.canonicalize().map_err(|e| {
        Issue::new(
            program_span.clone(),
            Some("program"),
            format!("{}: {e}", program.display()),
        )
    })?;
    check_executable(&program).map_err(|m| Issue::new(program_span.clone(), Some("program"), m))?;
    let program_hash = hash_file(&program).map_err(|e| {
        Issue::new(
            program_span.clone(),
            Some("program"),
            format!("cannot read {}: {e}", program.display()),
        )
    })?;
    let args = string_list(table, "args")?;
    let timeout_s = match table.get("timeout_s") {
        None => None,
        Some(value) => {
            let x = match value.get_ref() {
                DeValue::Integer(i) => i.as_str().parse::<f64>().ok(),
                DeValue::Float(f) => f.as_str().parse::<f64>().ok(),
                _ => None,
            };
            match x {
                Some(x) if x > 0.0 && x <= MAX_TIME_CAP_S => Some(x),
                _ => {
                    return Err(Issue::new(
                        value.span(),
                        Some("timeout_s"),
                        format!("must be a number of seconds in (0, {MAX_TIME_CAP_S}]"),
                    ));
                }
            }
        }
    };
    let values = regexes(table)?;

    // The parameters, in file order, each with its values; `seed` from the plan unless given.
    let mut names: Vec<(&str, Range<usize>)> = table
        .iter()
        .map(|(k, v)| (k.get_ref().as_ref(), v.span()))
        .filter(|(k, _)| !RESERVED.contains(k))
        .collect();
    names.sort_by_key(|(_, span)| span.start);
    let mut columns: Vec<(String, Vec<Written>)> = Vec::new();
    for (name, _) in &names {
        let values = sweep.values(name)?.unwrap_or_default();
        columns.push((name.to_string(), values));
    }
    if !columns.iter().any(|(k, _)| k == "seed") {
        let seed = toml::Value::Integer(i64::try_from(defaults.seed).unwrap_or(i64::MAX));
        columns.push(("seed".to_owned(), vec![(header.clone(), seed)]));
    }
    let args_span = sweep.span_of("args");
    // Every placeholder must name a parameter, whatever the point.
    let names_known: Vec<&str> = columns.iter().map(|(k, _)| k.as_str()).collect();
    for arg in &args {
        substitute(arg, &|name| {
            names_known
                .contains(&name)
                .then(String::new)
                .ok_or_else(|| {
                    format!(
                        "`{{{name}}}` names no parameter of this sweep (have: {})",
                        names_known.join(", ")
                    )
                })
        })
        .map_err(|m| Issue::new(args_span.clone(), Some("args"), m))?;
    }

    let lens: Vec<usize> = columns.iter().map(|(_, v)| v.len()).collect();
    check_product(sweep, &lens)?;
    cartesian(&lens)
        .map(|i| {
            let mut params = BTreeMap::new();
            for ((name, values), &k) in columns.iter().zip(&i) {
                let (span, value) = &values[k];
                let json = json_value(value)
                    .map_err(|m| Issue::new(span.clone(), Some(name.as_str()), m))?;
                params.insert(name.clone(), json);
            }
            let args = args
                .iter()
                .map(|arg| {
                    substitute(arg, &|name| {
                        params.get(name).map(text).ok_or_else(|| name.to_owned())
                    })
                    .map_err(|m| Issue::new(args_span.clone(), Some("args"), m))
                })
                .collect::<Result<Vec<String>, Issue>>()?;
            Ok(JobSpec::Command(CommandSpec {
                label: label.clone(),
                program: program.display().to_string(),
                program_hash: program_hash.clone(),
                args,
                params,
                timeout_s,
                values: values.clone(),
            }))
        })
        .collect()
}

fn string_key(table: &DeTable<'_>, key: &str, header: &Range<usize>) -> Result<String, Issue> {
    match table.get(key) {
        None => Err(Issue::new(
            header.clone(),
            Some(key),
            "missing (this key has no default)",
        )),
        Some(value) => match value.get_ref() {
            DeValue::String(s) if !s.trim().is_empty() => Ok(s.to_string()),
            other => Err(Issue::new(
                value.span(),
                Some(key),
                format!("must be a non-empty string, got {}", other.type_str()),
            )),
        },
    }
}

fn string_list(table: &DeTable<'_>, key: &str) -> Result<Vec<String>, Issue> {
    let Some(value) = table.get(key) else {
        return Ok(Vec::new());
    };
    let DeValue::Array(items) = value.get_ref() else {
        return Err(Issue::new(
            value.span(),
            Some(key),
            "must be a list of strings",
        ));
    };
    items
        .iter()
        .map(|item| match item.get_ref() {
            DeValue::String(s) => Ok(s.to_string()),
            other => Err(Issue::new(
                item.span(),
                Some(key),
                format!("must be a list of strings, got {} in it", other.type_str()),
            )),
        })
        .collect()
}

/// `[command.values]`: name → regex with exactly one capture group.
fn regexes(table: &DeTable<'_>) -> Result<BTreeMap<String, String>, Issue> {
    let Some(value) = table.get("values") else {
        return Ok(BTreeMap::new());
    };
    let DeValue::Table(entries) = value.get_ref() else {
        return Err(Issue::new(
            value.span(),
            Some("values"),
            "must be a table of name = \"regex with one capture group\"",
        ));
    };
    let mut out = BTreeMap::new();
    for (name, pattern) in entries {
        let key = format!("values.{}", name.get_ref());
        let DeValue::String(text) = pattern.get_ref() else {
            return Err(Issue::new(
                pattern.span(),
                Some(&key),
                "must be a regex (a string)",
            ));
        };
        let regex = regex::Regex::new(text)
            .map_err(|e| Issue::new(pattern.span(), Some(&key), format!("not a regex: {e}")))?;
        let groups = regex.captures_len() - 1;
        if groups != 1 {
            return Err(Issue::new(
                pattern.span(),
                Some(&key),
                format!("must have exactly one capture group, has {groups}"),
            ));
        }
        out.insert(name.get_ref().to_string(), text.to_string());
    }
    Ok(out)
}

fn check_executable(path: &Path) -> Result<(), String> {
    let meta = std::fs::metadata(path).map_err(|e| format!("{}: {e}", path.display()))?;
    if !meta.is_file() {
        return Err(format!("{} is not a file", path.display()));
    }
    if meta.permissions().mode() & 0o111 == 0 {
        return Err(format!("{} is not executable", path.display()));
    }
    Ok(())
}

fn json_value(value: &toml::Value) -> Result<Value, String> {
    match value {
        toml::Value::Integer(n) => Ok(Value::from(*n)),
        toml::Value::Float(x) if x.is_finite() => Ok(Value::from(*x)),
        toml::Value::String(s) => Ok(Value::from(s.as_str())),
        toml::Value::Boolean(b) => Ok(Value::from(*b)),
        other => Err(format!(
            "a parameter must be a number, a string or a boolean, got {}",
            other.type_str()
        )),
    }
}

/// A parameter as its argument text: integers as integers, reals as Rust prints them (the
/// shortest text that reads back the same), strings as they are.
fn text(value: &Value) -> String {
    match value {
        Value::String(s) => s.clone(),
        Value::Number(n) => match (n.as_i64(), n.as_f64()) {
            (Some(i), _) => i.to_string(),
            (None, Some(x)) => x.to_string(),
            _ => n.to_string(),
        },
        other => other.to_string(),
    }
}

/// `arg` with each `{name}` replaced by `lookup(name)`; `{{` and `}}` are literal braces.
fn substitute(
    arg: &str,
    lookup: &dyn Fn(&str) -> Result<String, String>,
) -> Result<String, String> {
    let mut out = String::with_capacity(arg.len());
    let mut rest = arg;
    while let Some(at) = rest.find(['{', '}']) {
        out.push_str(&rest[..at]);
        let tail = &rest[at..];
        if tail.starts_with("{{") || tail.starts_with("}}") {
            out.push_str(&tail[..1]);
            rest = &tail[2..];
        } else if tail.starts_with('}') {
            return Err(format!("`{arg}`: a lone `}}` (write `}}}}` for a brace)"));
        } else {
            let end = tail
                .find('}')
                .ok_or_else(|| format!("`{arg}`: `{{` without its `}}`"))?;
            out.push_str(&lookup(&tail[1..end])?);
            rest = &tail[end + 1..];
        }
    }
    out.push_str(rest);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placeholders_are_substituted() {
        let lookup = |name: &str| match name {
            "n" => Ok("256".to_owned()),
            other => Err(format!("unknown {other}")),
        };
        assert_eq!(substitute("--n={n}", &lookup), Ok("--n=256".to_owned()));
        assert_eq!(substitute("{{n}}", &lookup), Ok("{n}".to_owned()));
        assert!(substitute("{m}", &lookup).is_err());
        assert!(substitute("{n", &lookup).is_err());
        assert_eq!(text(&Value::from(0.45)), "0.45");
        assert_eq!(text(&Value::from(256)), "256");
    }
}
