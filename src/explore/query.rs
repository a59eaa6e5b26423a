//! A request's query string, read with the command line's rules: every field checked,
//! errors naming the field, its value and what is allowed.

use jeffcott_core::error::{Error, Result};
use std::collections::HashMap;

/// Fields of one query at most.
const MAX_FIELDS: usize = 64;

/// The fields of a query string (`a=1&b=2`), percent-decoded.
#[derive(Debug, Default)]
pub struct Query(HashMap<String, String>);

impl Query {
    /// Parses a query string; a repeated field or more than 64 fields is an error.
    pub fn parse(text: &str) -> Result<Query> {
        let mut map = HashMap::new();
        for (k, v) in form_urlencoded::parse(text.as_bytes()) {
            if map.len() >= MAX_FIELDS {
                return Err(Error::invalid(
                    "query",
                    map.len() + 1,
                    format!("at most {MAX_FIELDS} fields"),
                ));
            }
            if map.insert(k.to_string(), v.to_string()).is_some() {
                return Err(Error::invalid(&k, v, "is given twice"));
            }
        }
        Ok(Query(map))
    }

    /// A field's text, if present.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.0.get(key).map(String::as_str)
    }

    /// The fields whose names start with `prefix`, without it, in name order.
    pub fn prefixed<'a>(&'a self, prefix: &'a str) -> Vec<(&'a str, &'a str)> {
        let mut v: Vec<(&str, &str)> = self
            .0
            .iter()
            .filter_map(|(k, v)| Some((k.strip_prefix(prefix)?, v.as_str())))
            .collect();
        v.sort();
        v
    }

    /// A text field, or `default`.
    pub fn text<'a>(&'a self, key: &str, default: &'a str) -> Result<&'a str> {
        Ok(self.get(key).unwrap_or(default))
    }

    /// A finite number, or `default` when absent (an error when there is none).
    pub fn number(&self, key: &str, default: Option<f64>) -> Result<f64> {
        match (self.get(key), default) {
            (Some(s), _) => number(key, s),
            (None, Some(d)) => Ok(d),
            (None, None) => Err(Error::invalid(key, "(absent)", "is required")),
        }
    }

    /// A whole number in [lo, hi], or `default` when absent.
    pub fn count(&self, key: &str, default: u32, lo: u32, hi: u32) -> Result<u32> {
        let Some(s) = self.get(key) else {
            return Ok(default);
        };
        match s.trim().parse::<u32>() {
            Ok(v) if (lo..=hi).contains(&v) => Ok(v),
            _ => Err(Error::invalid(
                key,
                s,
                format!("must be a whole number from {lo} to {hi}"),
            )),
        }
    }

    /// A start coordinate by name (x_r, vx_r, ...), or `default`.
    pub fn coord(&self, key: &str, default: &str) -> Result<usize> {
        jeffcott_core::inputs::coord(key, self.text(key, default)?)
    }
}

/// A finite number from text (spaces around it allowed), the error naming `field`.
pub fn number(field: &str, text: &str) -> Result<f64> {
    jeffcott_analysis::basin::finite_number(field, text, text.trim())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_decoded_and_checked_with_the_field_named() {
        let q = Query::parse("lo=1.5&coord=vx_s&p.mu=0.1&n=7&name=a%20b").unwrap();
        assert_eq!(q.number("lo", None).unwrap(), 1.5);
        assert_eq!(q.coord("coord", "x_r").unwrap(), 5);
        assert_eq!(q.prefixed("p."), vec![("mu", "0.1")]);
        assert_eq!(q.get("name"), Some("a b"));
        let e = q.count("n", 1, 8, 9).unwrap_err().to_string();
        assert!(e.contains("n") && e.contains("8 to 9"), "{e}");
        let e = Query::parse("x=nan")
            .unwrap()
            .number("x", None)
            .unwrap_err();
        assert!(e.to_string().contains("finite"), "{e}");
        assert!(Query::parse("a=1&a=2").is_err());
        let many: Vec<String> = (0..65).map(|i| format!("f{i}=1")).collect();
        assert!(Query::parse(&many.join("&")).is_err());
    }
}
