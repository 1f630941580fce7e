//! Who may do what: the one policy every request passes, and the credentials it reads.
//!
//! - A state change (any `POST` but the login form) needs the token, always, from anywhere.
//! - Reading needs the token too, unless both the server's address and the client's are
//!   loopback: then the page is read-only for anyone on the machine, as `sweep status --db` is.
//! - The token comes as `Authorization: Bearer TOKEN` (scripts) or as the session cookie that the
//!   login form sets (browsers): HttpOnly, SameSite=Strict (no other site can make the browser
//!   send it, so no cross-site request can cancel), Secure over TLS. The cookie holds a value
//!   derived from the token, not the token. Both are compared in constant time.

use std::net::SocketAddr;

use axum::extract::connect_info::Connected;
use axum::http::{HeaderMap, Method, header};
use axum::serve::IncomingStream;
use tokio::net::TcpListener;
use wire::auth::Token;

use crate::tls::TlsListener;

/// The session cookie's name.
pub const COOKIE: &str = "sweep_session";
/// What the cookie's value is derived for (a new purpose string logs every browser out).
const SESSION_PURPOSE: &str = "sweep status page session 2026-11 v1";

/// The client's address, as the listener saw it (a request without one is treated as remote).
#[derive(Clone, Copy, Debug)]
pub struct Peer(pub SocketAddr);

impl Connected<IncomingStream<'_, TcpListener>> for Peer {
    fn connect_info(stream: IncomingStream<'_, TcpListener>) -> Self {
        Peer(*stream.remote_addr())
    }
}

impl Connected<IncomingStream<'_, TlsListener>> for Peer {
    fn connect_info(stream: IncomingStream<'_, TlsListener>) -> Self {
        Peer(*stream.remote_addr())
    }
}

/// What a request asks for, as far as the policy cares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Asks {
    /// The login form and its submission: open to all, it is how one authenticates.
    Login,
    /// A read (GET or HEAD).
    Read,
    /// Anything that may change state (every other method).
    Change,
}

impl Asks {
    pub fn of(method: &Method, path: &str) -> Asks {
        if path == "/login" {
            Asks::Login
        } else if method == Method::GET || method == Method::HEAD {
            Asks::Read
        } else {
            Asks::Change
        }
    }
}

/// The policy's answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Decision {
    Allow,
    /// Needs the token (401; a browser asking for the page is sent to the login form).
    NeedToken,
}

/// The policy. `local`: the server listens on loopback and this client connects from loopback.
pub fn decide(asks: Asks, local: bool, authenticated: bool) -> Decision {
    match asks {
        Asks::Login => Decision::Allow,
        Asks::Read if local || authenticated => Decision::Allow,
        Asks::Change if authenticated => Decision::Allow,
        Asks::Read | Asks::Change => Decision::NeedToken,
    }
}

/// Checks credentials against the coordinator's token (none configured: nobody authenticates).
#[derive(Clone)]
pub struct Credentials {
    token: Option<Token>,
}

impl Credentials {
    pub fn new(token: Option<Token>) -> Self {
        Credentials { token }
    }

    pub fn configured(&self) -> bool {
        self.token.is_some()
    }

    /// Whether the token is `presented`, in constant time.
    pub fn token_matches(&self, presented: &str) -> bool {
        self.token.as_ref().is_some_and(|t| t.matches(presented))
    }

    /// The session cookie's value: hex of a key derived from the token.
    pub fn session_value(&self) -> Option<String> {
        self.token
            .as_ref()
            .map(|t| t.derive(SESSION_PURPOSE).to_hex().to_string())
    }

    /// Whether the request carries the bearer token or a valid session cookie.
    pub fn authenticated(&self, headers: &HeaderMap) -> bool {
        let Some(token) = &self.token else {
            return false;
        };
        let bearer = headers
            .get_all(header::AUTHORIZATION)
            .iter()
            .filter_map(|v| v.to_str().ok())
            .filter_map(|v| v.strip_prefix("Bearer "))
            .any(|presented| token.matches(presented.trim()));
        bearer || {
            let expected = token.derive(SESSION_PURPOSE);
            cookies(headers, COOKIE).any(|value| {
                // blake3::Hash's PartialEq is constant-time.
                blake3::Hash::from_hex(value).is_ok_and(|presented| presented == expected)
            })
        }
    }
}

/// Every value of cookie `name` in the request's `Cookie` headers.
fn cookies<'a>(headers: &'a HeaderMap, name: &'a str) -> impl Iterator<Item = &'a str> + 'a {
    headers
        .get_all(header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(';'))
        .filter_map(move |pair| {
            let (key, value) = pair.trim().split_once('=')?;
            (key == name).then_some(value)
        })
}

/// Whether this server and this client are both on loopback.
pub fn is_local(listen: SocketAddr, peer: Option<Peer>) -> bool {
    listen.ip().is_loopback() && peer.is_some_and(|Peer(addr)| addr.ip().is_loopback())
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::http::HeaderValue;

    #[test]
    fn the_policy_table() {
        use Asks::*;
        use Decision::*;
        // (asks, local, authenticated) -> decision: every combination.
        let table = [
            (Login, false, false, Allow),
            (Login, true, false, Allow),
            (Read, true, false, Allow),
            (Read, false, false, NeedToken),
            (Read, false, true, Allow),
            (Read, true, true, Allow),
            (Change, true, false, NeedToken),
            (Change, false, false, NeedToken),
            (Change, true, true, Allow),
            (Change, false, true, Allow),
        ];
        for (asks, local, authenticated, expected) in table {
            assert_eq!(
                decide(asks, local, authenticated),
                expected,
                "{asks:?} local={local} auth={authenticated}"
            );
        }
    }

    #[test]
    fn only_get_and_head_read() {
        assert_eq!(Asks::of(&Method::GET, "/api/campaigns"), Asks::Read);
        assert_eq!(Asks::of(&Method::HEAD, "/"), Asks::Read);
        for method in [
            Method::POST,
            Method::PUT,
            Method::DELETE,
            Method::PATCH,
            Method::OPTIONS,
        ] {
            assert_eq!(
                Asks::of(&method, "/api/campaigns/x/cancel"),
                Asks::Change,
                "{method}"
            );
        }
        assert_eq!(Asks::of(&Method::POST, "/login"), Asks::Login);
    }

    #[test]
    fn local_means_both_ends_on_loopback() {
        let lo: SocketAddr = "127.0.0.1:80".parse().unwrap();
        let lo6: SocketAddr = "[::1]:80".parse().unwrap();
        let remote: SocketAddr = "192.0.2.7:5000".parse().unwrap();
        let any: SocketAddr = "0.0.0.0:80".parse().unwrap();
        assert!(is_local(lo, Some(Peer(lo))));
        assert!(is_local(lo, Some(Peer(lo6))));
        assert!(!is_local(lo, Some(Peer(remote))));
        assert!(
            !is_local(any, Some(Peer(lo))),
            "a server listening off loopback trusts no peer"
        );
        assert!(!is_local(lo, None), "no peer address: treated as remote");
    }

    #[test]
    fn credentials_bearer_and_cookie() {
        let credentials = Credentials::new(Some(Token::new("s3cret").unwrap()));
        let with = |name: header::HeaderName, value: &str| {
            let mut headers = HeaderMap::new();
            headers.insert(name, HeaderValue::from_str(value).unwrap());
            headers
        };
        assert!(credentials.authenticated(&with(header::AUTHORIZATION, "Bearer s3cret")));
        assert!(!credentials.authenticated(&with(header::AUTHORIZATION, "Bearer s3cre")));
        assert!(!credentials.authenticated(&with(header::AUTHORIZATION, "s3cret")));
        let session = credentials.session_value().unwrap();
        assert_ne!(session, "s3cret", "the cookie is not the token");
        assert!(
            credentials.authenticated(&with(header::COOKIE, &format!("a=b; {COOKIE}={session}")))
        );
        assert!(!credentials.authenticated(&with(header::COOKIE, &format!("{COOKIE}=s3cret"))));
        assert!(!credentials.authenticated(&with(header::COOKIE, &format!("other={session}"))));
        let none = Credentials::new(None);
        assert!(!none.authenticated(&with(header::AUTHORIZATION, "Bearer s3cret")));
        assert!(none.session_value().is_none());
    }
}
