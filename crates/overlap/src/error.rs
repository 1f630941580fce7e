#[derive(Debug, thiserror::Error, PartialEq)]
pub enum OverlapError {
    /// A parameter out of its domain; `key` is the parameter's name as in plans (`l_star`, …).
    #[error("{key}: {reason}")]
    Invalid { key: &'static str, reason: String },
    /// An algorithm (a plugin) gave a verdict that differs from Eq. 2 decided exactly where
    /// rounding cannot explain it; `reason` names the verdicts and the configuration.
    #[error("{algorithm}: wrong verdict, not timed: {reason}")]
    WrongVerdict { algorithm: String, reason: String },
}
