//! Canonical JSON: the byte string a point's identity is hashed from.
//!
//! Two specs that mean the same point must give the same bytes whatever produced them, so:
//! object keys are sorted by their UTF-8 bytes (independently of whether some crate in the build
//! turned on `serde_json/preserve_order`), there is no whitespace, and a number is written by its
//! value, not by how it was typed: an integral float of magnitude below 2^53 is written as an
//! integer (`4.0` → `4`), any other float in Rust's shortest round-trip decimal form. Arrays keep
//! their order (an order that does not matter is normalised where the spec is built).

use serde_json::{Number, Value};

/// Largest magnitude below which every integer is exactly representable as an `f64`.
const EXACT_INTEGER_LIMIT: f64 = 9_007_199_254_740_992.0; // 2^53

/// Writes `value` canonically.
pub fn to_canonical_string(value: &Value) -> String {
    let mut out = String::new();
    write_value(value, &mut out);
    out
}

fn write_value(value: &Value, out: &mut String) {
    match value {
        Value::Null => out.push_str("null"),
        Value::Bool(b) => out.push_str(if *b { "true" } else { "false" }),
        Value::Number(n) => write_number(n, out),
        Value::String(s) => write_string(s, out),
        Value::Array(items) => {
            out.push('[');
            for (i, item) in items.iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                write_value(item, out);
            }
            out.push(']');
        }
        Value::Object(map) => {
            let mut entries: Vec<(&String, &Value)> = map.iter().collect();
            entries.sort_unstable_by(|a, b| a.0.as_bytes().cmp(b.0.as_bytes()));
            out.push('{');
            for (i, (key, item)) in entries.into_iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                write_string(key, out);
                out.push(':');
                write_value(item, out);
            }
            out.push('}');
        }
    }
}

fn write_number(n: &Number, out: &mut String) {
    if let Some(u) = n.as_u64() {
        out.push_str(&u.to_string());
    } else if let Some(i) = n.as_i64() {
        out.push_str(&i.to_string());
    } else if let Some(f) = n.as_f64() {
        if f == 0.0 {
            // -0.0 and 0.0 are the same parameter value.
            out.push('0');
        } else if f.fract() == 0.0 && f.abs() < EXACT_INTEGER_LIMIT {
            out.push_str(&(f as i64).to_string());
        } else {
            // Display of f64 is the shortest decimal that round-trips, never in exponent form.
            out.push_str(&f.to_string());
        }
    }
}

fn write_string(s: &str, out: &mut String) {
    // serde_json's escaping is deterministic; serialising a &str cannot fail.
    out.push_str(&Value::String(s.to_owned()).to_string());
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn keys_sorted_and_numbers_by_value() {
        let a = json!({"b": 4.0, "a": [1, 0.5, -0.0], "c": {"z": 1e-5, "y": "q\"s"}});
        let b = json!({"c": {"y": "q\"s", "z": 0.00001}, "a": [1.0, 0.5, 0], "b": 4});
        assert_eq!(to_canonical_string(&a), to_canonical_string(&b));
        assert_eq!(
            to_canonical_string(&a),
            r#"{"a":[1,0.5,0],"b":4,"c":{"y":"q\"s","z":0.00001}}"#
        );
    }

    #[test]
    fn large_and_fractional_floats_round_trip() {
        let v = json!([1e300, 0.1, 2.5e-12, 9007199254740993u64]);
        let s = to_canonical_string(&v);
        let back: Vec<f64> = serde_json::from_str(&s).expect("canonical JSON is JSON");
        assert_eq!(back[..3], [1e300, 0.1, 2.5e-12]);
        assert!(s.ends_with(",9007199254740993]"));
    }
}
