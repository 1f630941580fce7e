//! The names a user picks algorithms and precisions by.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::error::OverlapError;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Algorithm {
    Arvo,
    Qri,
    Qrf,
    Sse,
    Ocsi,
    OcsiBatch,
}

impl Algorithm {
    pub const ALL: [Algorithm; 6] = [
        Self::Arvo,
        Self::Qri,
        Self::Qrf,
        Self::Sse,
        Self::Ocsi,
        Self::OcsiBatch,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Self::Arvo => "arvo",
            Self::Qri => "qri",
            Self::Qrf => "qrf",
            Self::Sse => "sse",
            Self::Ocsi => "ocsi",
            Self::OcsiBatch => "ocsi_batch",
        }
    }
}

impl fmt::Display for Algorithm {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Algorithm {
    type Err = OverlapError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL.into_iter().find(|a| a.name() == s).ok_or_else(|| OverlapError::Invalid {
            key: "algorithms",
            reason: format!("unknown algorithm `{s}` (expected one of arvo, qri, qrf, sse, ocsi, ocsi_batch)"),
        })
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    F32,
    F64,
}

impl Precision {
    pub fn name(self) -> &'static str {
        match self {
            Self::F32 => "f32",
            Self::F64 => "f64",
        }
    }
}

impl fmt::Display for Precision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Precision {
    type Err = OverlapError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "f32" => Ok(Self::F32),
            "f64" => Ok(Self::F64),
            _ => Err(OverlapError::Invalid {
                key: "precision",
                reason: format!("unknown precision `{s}` (expected f32 or f64)"),
            }),
        }
    }
}
