//! The flag groups several commands share: credentials, a coordinator to talk to, TLS, the
//! status page.

use std::net::SocketAddr;
use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use wire::auth::Token;

#[derive(Args, Clone)]
pub struct AuthArgs {
    /// File holding the bearer token shared by coordinator and workers.
    #[arg(long)]
    token_file: Option<PathBuf>,
    /// The bearer token itself (prefer --token-file: the environment of a process can be read).
    #[arg(
        long = "token",
        env = "SWEEP_TOKEN",
        hide_env_values = true,
        hide = true
    )]
    token: Option<String>,
}

impl AuthArgs {
    /// The token file given, if any.
    pub fn token_file(&self) -> Option<&std::path::Path> {
        self.token_file.as_deref()
    }

    pub fn token(&self) -> anyhow::Result<Option<Token>> {
        let secret = match (&self.token_file, &self.token) {
            (Some(file), _) => std::fs::read_to_string(file)
                .with_context(|| format!("--token-file {}", file.display()))?,
            (None, Some(secret)) => secret.clone(),
            (None, None) => return Ok(None),
        };
        Ok(Some(Token::new(&secret).context("--token-file")?))
    }
}

/// A running coordinator and how to reach it.
#[derive(Args, Clone)]
pub struct ClientArgs {
    /// The coordinator, e.g. http://10.0.0.5:7070 (https:// with --ca).
    #[arg(long)]
    pub coordinator: String,
    #[command(flatten)]
    pub auth: AuthArgs,
    /// CA certificate (PEM) that signed the coordinator's TLS certificate.
    #[arg(long)]
    pub ca: Option<PathBuf>,
}

impl ClientArgs {
    pub fn ca_pem(&self) -> anyhow::Result<Option<Vec<u8>>> {
        self.ca
            .as_ref()
            .map(|p| std::fs::read(p).with_context(|| format!("--ca {}", p.display())))
            .transpose()
    }
}

/// A certificate to serve with.
#[derive(Args, Clone)]
pub struct TlsArgs {
    /// TLS certificate chain (PEM); with --tls-key, serve TLS.
    #[arg(long, requires = "tls_key")]
    pub tls_cert: Option<PathBuf>,
    #[arg(long, requires = "tls_cert")]
    pub tls_key: Option<PathBuf>,
}

impl TlsArgs {
    /// The certificate chain and key, read.
    pub fn read(&self) -> anyhow::Result<Option<(Vec<u8>, Vec<u8>)>> {
        match (&self.tls_cert, &self.tls_key) {
            (Some(cert), Some(key)) => Ok(Some((
                std::fs::read(cert).with_context(|| format!("--tls-cert {}", cert.display()))?,
                std::fs::read(key).with_context(|| format!("--tls-key {}", key.display()))?,
            ))),
            _ => Ok(None),
        }
    }
}

#[derive(Args, Clone)]
pub struct HttpArgs {
    /// Also serve the live status page (HTML, JSON, SVG figures) here, e.g. 127.0.0.1:8080; off
    /// loopback it needs the token, which anyone must also present to cancel from the page.
    #[arg(long, value_name = "ADDR")]
    pub http: Option<SocketAddr>,
}
