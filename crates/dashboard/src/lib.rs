//! The live status page of a coordinator (`sweep coordinator --http ADDR`, `sweep run --http
//! ADDR`), served on the coordinator's own tokio runtime: one HTML page (with its script and
//! style, compiled in: nothing is fetched from elsewhere), JSON for everything it shows, and the
//! campaign's figures as SVG drawn by the `report` crate.
//!
//! Map of the crate:
//! - [`access`]: the policy (read-only on loopback without the token, nothing else without it;
//!   a state change always needs it) and the bearer header / session cookie it reads.
//! - [`mod@snapshot`]: the sampler that reads the store every few seconds; requests read its
//!   latest sample, so pages cost the store nothing per request.
//! - [`figures`]: the figures and tables, drawn off the runtime and cached by the done count.
//! - `tls`: HTTPS with the coordinator's certificate.
//!
//! Routes: `GET /` (the page), `GET /login` and `POST /login` (the form that sets the session
//! cookie), `POST /logout`, `GET /api/snapshot` (all of it), `/api/campaigns`, `/api/workers`,
//! `/api/failures`, `/api/figures` (what can be drawn), `/api/figures/NAME.svg`,
//! `/api/tables/NAME.json`, and `POST /api/campaigns/ID/cancel` (the only state change).

pub mod access;
pub mod figures;
pub mod snapshot;
mod tls;

use std::net::SocketAddr;

use axum::Router;
use axum::body::{Body, Bytes};
use axum::extract::{ConnectInfo, Path, Request, State};
use axum::http::{HeaderValue, StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Redirect, Response};
use axum::routing::{get, post};
use coordinator::Coordinator;
use serde::Serialize;
use wire::auth::Token;

use crate::access::{Asks, COOKIE, Credentials, Decision, Peer};
use crate::figures::Figures;
use crate::snapshot::Sampler;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(
        "--http {0}: refusing a non-loopback address without a token (--token-file or SWEEP_TOKEN)"
    )]
    NoTokenOffLoopback(SocketAddr),
    #[error("--http {addr}: {source}")]
    Bind {
        addr: SocketAddr,
        source: std::io::Error,
    },
    #[error("status page TLS: {0}")]
    Tls(String),
    #[error("status page: {0}")]
    Store(#[from] store::Error),
    #[error("status page: {0}")]
    Results(#[from] results::Error),
    #[error("status page: {0}")]
    Io(#[from] std::io::Error),
}

/// Where and how to serve.
pub struct Options {
    pub listen: SocketAddr,
    /// The coordinator's token; without one nobody can change anything through the page.
    pub token: Option<Token>,
    /// PEM certificate chain and key: serve HTTPS.
    pub tls: Option<(Vec<u8>, Vec<u8>)>,
}

/// What every handler shares.
#[derive(Clone)]
struct App {
    coordinator: Coordinator,
    sampler: Sampler,
    figures: Figures,
    credentials: Credentials,
    listen: SocketAddr,
    secure_cookie: bool,
}

/// The router over a coordinator, with its sampler task (abort it to stop sampling). `listen`
/// is the address served on: the policy trusts loopback clients only when it is loopback.
pub async fn router(
    coordinator: Coordinator,
    listen: SocketAddr,
    token: Option<Token>,
    secure_cookie: bool,
) -> Result<(Router, tokio::task::JoinHandle<()>), Error> {
    let (sampler, sampling) = Sampler::start(coordinator.clone()).await?;
    let app = App {
        figures: Figures::new(coordinator.store().clone()),
        coordinator,
        sampler,
        credentials: Credentials::new(token),
        listen,
        secure_cookie,
    };
    let router = Router::new()
        .route("/", get(page))
        .route(
            "/page.js",
            get(|| async {
                asset(
                    "text/javascript; charset=utf-8",
                    include_str!("../page/page.js"),
                )
            }),
        )
        .route(
            "/page.css",
            get(|| async { asset("text/css; charset=utf-8", include_str!("../page/page.css")) }),
        )
        .route("/login", get(login_form).post(login))
        .route("/logout", post(logout))
        .route("/api/snapshot", get(snapshot))
        .route(
            "/api/campaigns",
            get(|State(app): State<App>| async move { json(&app.sampler.latest().campaigns) }),
        )
        .route(
            "/api/workers",
            get(|State(app): State<App>| async move { json(&app.sampler.latest().workers) }),
        )
        .route(
            "/api/failures",
            get(|State(app): State<App>| async move { json(&app.sampler.latest().failures) }),
        )
        .route(
            "/api/figures",
            get(|State(app): State<App>| async move { json(&app.sampler.latest().figures) }),
        )
        .route("/api/figures/{file}", get(figure))
        .route("/api/tables/{file}", get(table))
        .route("/api/campaigns/{id}/cancel", post(cancel))
        .layer(middleware::from_fn_with_state(app.clone(), guard))
        .with_state(app);
    Ok((router, sampling))
}

/// A bound, not yet serving, status page: binding first lets the caller print the address.
pub struct Bound {
    listener: tokio::net::TcpListener,
    tls: Option<tokio_rustls::TlsAcceptor>,
    options: Options,
}

/// Binds `options.listen`. A non-loopback address without a token is refused, as for gRPC.
pub async fn bind(options: Options) -> Result<Bound, Error> {
    if options.token.is_none() && !options.listen.ip().is_loopback() {
        return Err(Error::NoTokenOffLoopback(options.listen));
    }
    let tls = match &options.tls {
        Some((cert, key)) => Some(tls::acceptor(cert, key)?),
        None => None,
    };
    let listener = tokio::net::TcpListener::bind(options.listen)
        .await
        .map_err(|source| Error::Bind {
            addr: options.listen,
            source,
        })?;
    Ok(Bound {
        listener,
        tls,
        options,
    })
}

impl Bound {
    /// The address served, as `http://…/` or `https://…/`.
    pub fn url(&self) -> Result<String, Error> {
        let scheme = if self.tls.is_some() { "https" } else { "http" };
        Ok(format!("{scheme}://{}/", self.listener.local_addr()?))
    }

    /// Serves until `shutdown` resolves.
    pub async fn serve(
        self,
        coordinator: Coordinator,
        shutdown: impl std::future::Future<Output = ()> + Send + 'static,
    ) -> Result<(), Error> {
        let listen = self.listener.local_addr()?;
        let (router, sampling) =
            router(coordinator, listen, self.options.token, self.tls.is_some()).await?;
        let service = router.into_make_service_with_connect_info::<Peer>();
        let served = match self.tls {
            Some(acceptor) => {
                let listener = tls::TlsListener::new(self.listener, acceptor)?;
                axum::serve(listener, service)
                    .with_graceful_shutdown(shutdown)
                    .await
            }
            None => {
                axum::serve(self.listener, service)
                    .with_graceful_shutdown(shutdown)
                    .await
            }
        };
        sampling.abort();
        Ok(served?)
    }
}

/// The policy of [`access`], before every handler. Handlers see whether the request is
/// authenticated through the [`Authenticated`] extension.
async fn guard(State(app): State<App>, mut request: Request, next: Next) -> Response {
    let peer = request.extensions().get::<ConnectInfo<Peer>>().map(|c| c.0);
    let local = access::is_local(app.listen, peer);
    let authenticated = app.credentials.authenticated(request.headers());
    let asks = Asks::of(request.method(), request.uri().path());
    match access::decide(asks, local, authenticated) {
        Decision::Allow => {
            request
                .extensions_mut()
                .insert(Authenticated(authenticated));
            let mut response = next.run(request).await;
            // Nothing here may be framed by another site or cached by a proxy.
            let headers = response.headers_mut();
            headers.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
            headers.insert("x-frame-options", HeaderValue::from_static("DENY"));
            headers.insert(
                "x-content-type-options",
                HeaderValue::from_static("nosniff"),
            );
            response
        }
        Decision::NeedToken if asks == Asks::Read && request.uri().path() == "/" => {
            Redirect::to("/login").into_response()
        }
        Decision::NeedToken => {
            let why = match asks {
                Asks::Change => {
                    "changing anything needs the token (Authorization: Bearer, or log in at /login)"
                }
                _ => {
                    "off loopback, the status page needs the token (Authorization: Bearer, or log in at /login)"
                }
            };
            error(StatusCode::UNAUTHORIZED, why)
        }
    }
}

#[derive(Clone, Copy)]
struct Authenticated(bool);

fn asset(content_type: &'static str, body: &'static str) -> Response {
    ([(header::CONTENT_TYPE, content_type)], body).into_response()
}

fn json(value: &impl Serialize) -> Response {
    match serde_json::to_string(value) {
        Ok(text) => ([(header::CONTENT_TYPE, "application/json")], text).into_response(),
        Err(e) => error(StatusCode::INTERNAL_SERVER_ERROR, &e.to_string()),
    }
}

fn error(status: StatusCode, message: &str) -> Response {
    let body = serde_json::json!({ "error": message }).to_string();
    (status, [(header::CONTENT_TYPE, "application/json")], body).into_response()
}

async fn page() -> Response {
    asset(
        "text/html; charset=utf-8",
        include_str!("../page/index.html"),
    )
}

async fn snapshot(State(app): State<App>, request: Request) -> Response {
    let authenticated = request
        .extensions()
        .get::<Authenticated>()
        .is_some_and(|a| a.0);
    #[derive(Serialize)]
    struct WithSession<'a> {
        authenticated: bool,
        token_configured: bool,
        #[serde(flatten)]
        snapshot: &'a snapshot::Snapshot,
    }
    let latest = app.sampler.latest();
    json(&WithSession {
        authenticated,
        token_configured: app.credentials.configured(),
        snapshot: &latest,
    })
}

/// `NAME.svg` → NAME.
fn strip<'a>(file: &'a str, extension: &str) -> Option<&'a str> {
    file.strip_suffix(extension)
}

async fn figure(State(app): State<App>, Path(file): Path<String>) -> Response {
    drawn(
        &app,
        strip(&file, ".svg").and_then(|name| figures::find(name, false)),
        "image/svg+xml",
    )
    .await
}

async fn table(State(app): State<App>, Path(file): Path<String>) -> Response {
    drawn(
        &app,
        strip(&file, ".json").and_then(|name| figures::find(name, true)),
        "application/json",
    )
    .await
}

async fn drawn(app: &App, figure: Option<figures::Figure>, content_type: &'static str) -> Response {
    let Some(figure) = figure else {
        return error(
            StatusCode::NOT_FOUND,
            "no such figure (figures: fig2, fig3, fig7, fig13 as .svg; tables: table1, table2 as .json)",
        );
    };
    let latest = app.sampler.latest();
    if !latest.done_by_kind.iter().any(|(k, _)| k == figure.kind()) {
        return error(
            StatusCode::NOT_FOUND,
            &format!(
                "{} needs done {} jobs (none yet)",
                figure.name,
                figure.kind()
            ),
        );
    }
    let done = latest.done_total;
    let drawn = app.figures.get(figure, done).await;
    match drawn.body {
        Ok(body) => Response::builder()
            .header(header::CONTENT_TYPE, content_type)
            .header("x-sweep-done", drawn.done)
            .body(Body::from(body.as_str().to_owned()))
            .unwrap_or_else(|e| error(StatusCode::INTERNAL_SERVER_ERROR, &e.to_string())),
        Err(why) => error(
            StatusCode::NOT_FOUND,
            &format!("{}: nothing to draw yet: {why}", figure.name),
        ),
    }
}

async fn cancel(State(app): State<App>, Path(id): Path<String>) -> Response {
    match app.coordinator.cancel(&id).await {
        Ok(cancelled) => {
            tracing::info!(campaign = %id, cancelled, "cancelled from the status page");
            app.sampler.refresh();
            json(&serde_json::json!({ "campaign": id, "cancelled": cancelled }))
        }
        Err(coordinator::Error::Store(store::Error::UnknownCampaign(_))) => {
            error(StatusCode::NOT_FOUND, &format!("no campaign {id}"))
        }
        Err(e) => error(StatusCode::INTERNAL_SERVER_ERROR, &e.to_string()),
    }
}

const LOGIN_FORM: &str = include_str!("../page/login.html");

async fn login_form(State(app): State<App>) -> Response {
    let note = if app.credentials.configured() {
        ""
    } else {
        "<p class=\"bad\">This coordinator has no token (--token-file): nobody can log in, and nothing can be changed from the page.</p>"
    };
    asset_owned(StatusCode::OK, LOGIN_FORM.replace("<!--note-->", note))
}

fn asset_owned(status: StatusCode, html: String) -> Response {
    (
        status,
        [(header::CONTENT_TYPE, "text/html; charset=utf-8")],
        html,
    )
        .into_response()
}

/// The form posts `token=…`; the right token sets the session cookie and goes to the page.
async fn login(State(app): State<App>, body: Bytes) -> Response {
    let presented = form_urlencoded::parse(&body)
        .find(|(k, _)| k == "token")
        .map(|(_, v)| v.into_owned());
    let session = app.credentials.session_value();
    match (presented, session) {
        (Some(token), Some(session)) if app.credentials.token_matches(token.trim()) => {
            let secure = if app.secure_cookie { "; Secure" } else { "" };
            let cookie = format!("{COOKIE}={session}; HttpOnly; SameSite=Strict; Path=/{secure}");
            let mut response = Redirect::to("/").into_response();
            if let Ok(value) = HeaderValue::from_str(&cookie) {
                response.headers_mut().insert(header::SET_COOKIE, value);
            }
            response
        }
        _ => {
            // Slows guessing; the token is compared in constant time regardless.
            tokio::time::sleep(std::time::Duration::from_millis(500)).await;
            let html = LOGIN_FORM.replace("<!--note-->", "<p class=\"bad\">Wrong token.</p>");
            asset_owned(StatusCode::UNAUTHORIZED, html)
        }
    }
}

async fn logout() -> Response {
    let mut response = Redirect::to("/login").into_response();
    let expired = format!("{COOKIE}=; HttpOnly; SameSite=Strict; Path=/; Max-Age=0");
    if let Ok(value) = HeaderValue::from_str(&expired) {
        response.headers_mut().insert(header::SET_COOKIE, value);
    }
    response
}

#[cfg(test)]
mod tests {
    #[test]
    fn figure_file_names() {
        assert_eq!(super::strip("fig2.svg", ".svg"), Some("fig2"));
        assert_eq!(super::strip("fig2.png", ".svg"), None);
        assert!(super::figures::find("fig2", false).is_some());
        assert!(
            super::figures::find("fig2", true).is_none(),
            "fig2 is not a table"
        );
        assert!(super::figures::find("table1", true).is_some());
        assert!(super::figures::find("fig99", false).is_none());
    }
}
