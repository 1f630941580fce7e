#[derive(Debug, thiserror::Error, PartialEq)]
pub enum OverlapError {
    /// A parameter out of its domain; `key` is the parameter's name as in plans (`l_star`, …).
    #[error("{key}: {reason}")]
    Invalid { key: &'static str, reason: String },
}
