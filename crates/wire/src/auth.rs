//! Bearer-token authentication of every RPC, and TLS settings, shared by both ends.

use std::sync::Arc;

use tonic::metadata::MetadataValue;
use tonic::service::Interceptor;
use tonic::{Request, Status};

/// A shared secret. Compared through its BLAKE3 digest in constant time, so neither the
/// content nor the length of the expected token leaks through timing.
#[derive(Clone)]
pub struct Token {
    digest: [u8; 32],
    header: MetadataValue<tonic::metadata::Ascii>,
}

#[derive(Debug, thiserror::Error)]
pub enum TokenError {
    #[error("the token is empty")]
    Empty,
    #[error("the token must be printable ASCII without spaces")]
    NotPrintable,
}

impl Token {
    pub fn new(secret: &str) -> Result<Token, TokenError> {
        let secret = secret.trim();
        if secret.is_empty() {
            return Err(TokenError::Empty);
        }
        if !secret.bytes().all(|b| b.is_ascii_graphic()) {
            return Err(TokenError::NotPrintable);
        }
        let header = format!("Bearer {secret}")
            .parse()
            .map_err(|_| TokenError::NotPrintable)?;
        Ok(Token {
            digest: *blake3::hash(secret.as_bytes()).as_bytes(),
            header,
        })
    }

    /// Whether `presented` is this token, in constant time.
    pub fn matches(&self, presented: &str) -> bool {
        let other = blake3::hash(presented.as_bytes());
        // blake3::Hash's PartialEq is constant-time.
        blake3::Hash::from(self.digest) == other
    }

    /// A secret derived from the token for one `purpose` (e.g. a browser session cookie): whoever
    /// holds it can prove they were given the token without the token itself travelling again.
    pub fn derive(&self, purpose: &str) -> blake3::Hash {
        blake3::Hash::from(blake3::derive_key(purpose, &self.digest))
    }
}

/// Server side: rejects a call without `authorization: Bearer <token>` matching the expected
/// token. `None` means authentication is off (only allowed on loopback, see the coordinator).
#[derive(Clone)]
pub struct RequireToken {
    expected: Option<Arc<Token>>,
}

impl RequireToken {
    pub fn new(expected: Option<Token>) -> Self {
        Self {
            expected: expected.map(Arc::new),
        }
    }
}

impl Interceptor for RequireToken {
    fn call(&mut self, request: Request<()>) -> Result<Request<()>, Status> {
        let Some(expected) = &self.expected else {
            return Ok(request);
        };
        let presented = request
            .metadata()
            .get("authorization")
            .and_then(|v| v.to_str().ok())
            .and_then(|v| v.strip_prefix("Bearer "));
        match presented {
            Some(token) if expected.matches(token) => Ok(request),
            _ => {
                let peer = request
                    .remote_addr()
                    .map_or_else(|| "unknown peer".to_string(), |a| a.to_string());
                tracing::warn!(%peer, "rejected an unauthenticated call");
                Err(Status::unauthenticated("missing or wrong bearer token"))
            }
        }
    }
}

/// Client side: adds the bearer token to every call.
#[derive(Clone)]
pub struct WithToken {
    token: Option<Arc<Token>>,
}

impl WithToken {
    pub fn new(token: Option<Token>) -> Self {
        Self {
            token: token.map(Arc::new),
        }
    }
}

impl Interceptor for WithToken {
    fn call(&mut self, mut request: Request<()>) -> Result<Request<()>, Status> {
        if let Some(token) = &self.token {
            request
                .metadata_mut()
                .insert("authorization", token.header.clone());
        }
        Ok(request)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn call(interceptor: &mut RequireToken, header: Option<&str>) -> bool {
        let mut request = Request::new(());
        if let Some(h) = header {
            request
                .metadata_mut()
                .insert("authorization", h.parse().unwrap());
        }
        interceptor.call(request).is_ok()
    }

    #[test]
    fn only_the_right_bearer_token_passes() {
        let mut auth = RequireToken::new(Some(Token::new("s3cret").unwrap()));
        assert!(call(&mut auth, Some("Bearer s3cret")));
        assert!(!call(&mut auth, Some("Bearer s3cre")));
        assert!(!call(&mut auth, Some("Bearer s3cret2")));
        assert!(!call(&mut auth, Some("s3cret")));
        assert!(!call(&mut auth, Some("Basic s3cret")));
        assert!(!call(&mut auth, None));
        assert!(
            call(&mut RequireToken::new(None), None),
            "authentication off"
        );
    }

    #[test]
    fn the_client_sends_what_the_server_expects() {
        let token = Token::new(" s3cret\n").unwrap();
        let request = WithToken::new(Some(token.clone()))
            .call(Request::new(()))
            .unwrap();
        let header = request
            .metadata()
            .get("authorization")
            .unwrap()
            .to_str()
            .unwrap()
            .to_string();
        assert!(call(&mut RequireToken::new(Some(token)), Some(&header)));
    }

    #[test]
    fn empty_or_unprintable_tokens_are_refused() {
        assert!(matches!(Token::new("  \n"), Err(TokenError::Empty)));
        assert!(matches!(
            Token::new("two words"),
            Err(TokenError::NotPrintable)
        ));
    }
}
