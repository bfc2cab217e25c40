//! The studio's state as `make` options: each long option's value as a string, as on the command
//! line, so the state *is* a command line and the command line reproduces it.

use std::collections::BTreeMap;

use serde_json::Value as Json;

/// How an option takes its value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    /// A switch: `"true"` / `"false"`.
    Flag,
    /// One value (`""` when not given).
    Value,
    /// Repeatable: an array of values.
    List,
}

/// One `make` option, as the page lists it.
#[derive(Clone, Debug, serde::Serialize)]
pub struct OptionSpec {
    /// The long name without dashes (`"threshold"`).
    pub name: String,
    /// How it takes its value.
    pub kind: Kind,
    /// What `make` takes when it is not given (empty when nothing).
    pub default: Vec<String>,
    /// The values it accepts, when it is a choice.
    pub choices: Vec<String>,
    /// The help heading it is listed under (`make --help`).
    pub group: String,
    /// Its help text (`make --help`).
    pub help: String,
}

/// One option's value as the page reads it ([`Params::to_json`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[serde(untagged)]
pub enum OptionValue {
    /// A switch's or a one-value option's (`""` when not given).
    One(String),
    /// A repeatable option's.
    List(Vec<String>),
}

/// The options' values, keyed by long name.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Params {
    values: BTreeMap<String, Vec<String>>,
}

/// A change the studio refuses before running anything.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ParamError {
    #[error("the body must be a JSON object of option names and values")]
    NotObject,
    #[error("'{0}' is not an option of make")]
    Unknown(String),
    #[error("the value of '{0}' must be \"true\" or \"false\"")]
    NotFlag(String),
    #[error("the value of '{0}' must be a string")]
    NotString(String),
    #[error("the value of '{0}' must be an array of strings")]
    NotList(String),
}

impl Params {
    /// Every option at its default.
    pub fn defaults(specs: &[OptionSpec]) -> Self {
        let values = specs
            .iter()
            .map(|s| {
                let v = match s.kind {
                    Kind::Flag => vec!["false".to_string()],
                    _ => s.default.clone(),
                };
                (s.name.clone(), v)
            })
            .collect();
        Params { values }
    }

    /// The values as the page reads them: a string per option, an array for a repeatable one.
    pub fn to_json(&self, specs: &[OptionSpec]) -> BTreeMap<String, OptionValue> {
        let value = |s: &OptionSpec| {
            let v = self.values.get(&s.name).cloned().unwrap_or_default();
            match s.kind {
                Kind::List => OptionValue::List(v),
                _ => OptionValue::One(v.into_iter().next().unwrap_or_default()),
            }
        };
        specs.iter().map(|s| (s.name.clone(), value(s))).collect()
    }

    /// These values with `changes` (a JSON object in the form [`Params::to_json`] gives) applied.
    pub fn with(&self, specs: &[OptionSpec], changes: &Json) -> Result<Params, ParamError> {
        let obj = changes.as_object().ok_or(ParamError::NotObject)?;
        let mut out = self.clone();
        for (k, v) in obj {
            let spec = specs
                .iter()
                .find(|s| &s.name == k)
                .ok_or_else(|| ParamError::Unknown(k.clone()))?;
            let vals = match spec.kind {
                Kind::Flag => match (v.as_str(), v.as_bool()) {
                    (Some(s @ ("true" | "false")), _) => vec![s.into()],
                    (_, Some(b)) => vec![b.to_string()],
                    _ => return Err(ParamError::NotFlag(k.clone())),
                },
                Kind::Value => match v {
                    Json::String(s) if s.is_empty() => Vec::new(),
                    Json::String(s) => vec![s.clone()],
                    _ => return Err(ParamError::NotString(k.clone())),
                },
                Kind::List => match v {
                    Json::String(s) => vec![s.clone()],
                    Json::Array(a) => a
                        .iter()
                        .map(|x| x.as_str().map(str::to_string))
                        .collect::<Option<Vec<_>>>()
                        .ok_or_else(|| ParamError::NotList(k.clone()))?,
                    _ => return Err(ParamError::NotList(k.clone())),
                },
            };
            out.values.insert(k.clone(), vals);
        }
        Ok(out)
    }

    /// The values of one option.
    pub fn get(&self, name: &str) -> &[String] {
        self.values.get(name).map_or(&[], |v| v.as_slice())
    }

    /// The arguments that give these values, the options left at their defaults left out, in the
    /// order `make --help` lists them. A value that starts with `-` is joined to its option
    /// (`--threshold=-1`): apart, a parser takes it for an option of its own, and the message
    /// ("unexpected argument '-1'") would name neither the option nor what it takes.
    pub fn args(&self, specs: &[OptionSpec]) -> Vec<String> {
        let mut out = Vec::new();
        for s in specs {
            let v = self.get(&s.name);
            let flag = format!("--{}", s.name);
            match s.kind {
                Kind::Flag => {
                    if v.first().map(String::as_str) == Some("true") {
                        out.push(flag);
                    }
                }
                _ if v == s.default.as_slice() => {}
                Kind::Value => {
                    if let Some(x) = v.first() {
                        push_value(&mut out, &flag, x);
                    }
                }
                Kind::List => {
                    for x in v {
                        push_value(&mut out, &flag, x);
                    }
                }
            }
        }
        out
    }
}

/// `--name value`, or `--name=value` when the value starts with `-` (see [`Params::args`]).
fn push_value(out: &mut Vec<String>, flag: &str, value: &str) {
    if value.starts_with('-') {
        out.push(format!("{flag}={value}"));
    } else {
        out.push(flag.to_string());
        out.push(value.to_string());
    }
}

/// A word as a POSIX shell reads it back: as is when it is safe, else in single quotes.
pub fn shell_quote(s: &str) -> String {
    let safe = !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./,:=+@%".contains(c));
    if safe {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn specs() -> Vec<OptionSpec> {
        let o = |name: &str, kind, default: &[&str]| OptionSpec {
            name: name.into(),
            kind,
            default: default.iter().map(|s| s.to_string()).collect(),
            choices: vec![],
            group: String::new(),
            help: String::new(),
        };
        vec![
            o("threshold", Kind::Value, &["128"]),
            o("invert", Kind::Flag, &[]),
            o("width-mm", Kind::Value, &[]),
            o("bridge-at", Kind::List, &[]),
        ]
    }

    #[test]
    fn changes_make_arguments_and_defaults_are_left_out() {
        let s = specs();
        let p = Params::defaults(&s);
        assert!(p.args(&s).is_empty());
        let c =
            serde_json::json!({"threshold": "90", "invert": "true", "bridge-at": ["1,2", "3,4"]});
        let q = p.with(&s, &c).unwrap();
        assert_eq!(
            q.args(&s),
            [
                "--threshold",
                "90",
                "--invert",
                "--bridge-at",
                "1,2",
                "--bridge-at",
                "3,4"
            ]
        );
        let back = q
            .with(
                &s,
                &serde_json::json!({"threshold": "128", "invert": "false", "bridge-at": []}),
            )
            .unwrap();
        assert_eq!(back, p);
        assert_eq!(
            p.with(&s, &serde_json::json!({"nope": "1"})),
            Err(ParamError::Unknown("nope".into()))
        );
        assert_eq!(
            p.with(&s, &serde_json::json!({"invert": "yes"})),
            Err(ParamError::NotFlag("invert".into()))
        );
        let json = serde_json::to_value(q.to_json(&s)).unwrap();
        assert_eq!(json["bridge-at"], serde_json::json!(["1,2", "3,4"]));
        assert_eq!(json["width-mm"], serde_json::json!(""));
        // A value that looks like an option stays the option's value.
        let n = p
            .with(
                &s,
                &serde_json::json!({"threshold": "-1", "bridge-at": ["-2,3"]}),
            )
            .unwrap();
        assert_eq!(n.args(&s), ["--threshold=-1", "--bridge-at=-2,3"]);
    }

    #[test]
    fn quoting_survives_a_shell() {
        assert_eq!(shell_quote("samples/a.png"), "samples/a.png");
        assert_eq!(shell_quote("my pic's.png"), r"'my pic'\''s.png'");
        assert_eq!(shell_quote(""), "''");
    }
}
