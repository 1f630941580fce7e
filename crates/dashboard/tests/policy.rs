//! The status page's router over a real store, called in-process: the access policy with the
//! client's address set by the test (a remote client cannot be made on a machine without a
//! second interface, so its address is spoofed in the connection info the listener would set),
//! the cancel rules, the failures log, and HTTPS with a generated certificate.

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use axum::body::Body;
use axum::extract::ConnectInfo;
use axum::http::{Request, StatusCode, header};
use coordinator::{Config, Coordinator, NewCampaign, NewJob, Store, SystemClock, WorkerInfo};
use dashboard::access::Peer;
use tower::ServiceExt;
use wire::auth::Token;

const TOKEN: &str = "policy-test-token";

async fn coordinator(dir: &tempfile::TempDir, jobs: usize) -> Coordinator {
    let store = Store::open(dir.path().join("c.db")).await.unwrap();
    let config = Config {
        max_attempts: 2,
        ..Config::default()
    };
    let coordinator = Coordinator::new(store, config, Arc::new(SystemClock)).unwrap();
    let campaign = NewCampaign {
        id: "camp".into(),
        name: "policy".into(),
        plan_text: String::new(),
        searches: Vec::new(),
    };
    let jobs: Vec<NewJob> = (0..jobs)
        .map(|i| NewJob {
            id: format!("job-{i:03}"),
            kind: "noop".into(),
            params_json: format!(r#"{{"i":{i}}}"#),
            estimate_s: 1.0,
            exclusive: false,
            pass: 0,
            foreign_code: false,
        })
        .collect();
    coordinator.submit(&campaign, &jobs).await.unwrap();
    coordinator
}

fn worker(id: &str) -> WorkerInfo {
    WorkerInfo {
        id: id.into(),
        hostname: "host".into(),
        cores: vec![0, 1],
        cpu_model: "Test CPU".into(),
        cpu_flags: String::new(),
        rustc: "1.95".into(),
        git_commit: "0123456789ab".into(),
        profile: "release".into(),
        allocation: None,
        allow_commands: false,
    }
}

async fn router(coordinator: &Coordinator, listen: &str) -> Router {
    let listen: SocketAddr = listen.parse().unwrap();
    let (router, _sampler) = dashboard::router(
        coordinator.clone(),
        listen,
        Some(Token::new(TOKEN).unwrap()),
        false,
    )
    .await
    .unwrap();
    router
}

/// A request as the listener would hand it over from `peer`.
fn request(method: &str, path: &str, peer: &str, headers: &[(&str, &str)]) -> Request<Body> {
    let mut builder = Request::builder().method(method).uri(path);
    for (k, v) in headers {
        builder = builder.header(*k, *v);
    }
    let mut request = builder.body(Body::empty()).unwrap();
    request
        .extensions_mut()
        .insert(ConnectInfo(Peer(peer.parse().unwrap())));
    request
}

async fn call(
    router: &Router,
    request: Request<Body>,
) -> (StatusCode, axum::http::HeaderMap, String) {
    let response = router.clone().oneshot(request).await.unwrap();
    let (parts, body) = response.into_parts();
    let bytes = axum::body::to_bytes(body, usize::MAX).await.unwrap();
    (
        parts.status,
        parts.headers,
        String::from_utf8_lossy(&bytes).into_owned(),
    )
}

const LOOPBACK: &str = "127.0.0.1:40000";
const REMOTE: &str = "192.0.2.7:40000";
const BEARER: &str = "Bearer policy-test-token";

#[tokio::test]
async fn remote_clients_need_the_token_for_everything() {
    let dir = tempfile::tempdir().unwrap();
    let coordinator = coordinator(&dir, 3).await;
    // Listening off loopback: nobody is trusted without the token, not even a loopback peer.
    for listen in ["0.0.0.0:8080", "127.0.0.1:8080"] {
        let router = router(&coordinator, listen).await;
        for path in [
            "/api/snapshot",
            "/api/campaigns",
            "/api/workers",
            "/api/failures",
            "/api/figures",
            "/api/figures/fig2.svg",
            "/page.js",
        ] {
            let (status, _, body) = call(&router, request("GET", path, REMOTE, &[])).await;
            assert_eq!(
                status,
                StatusCode::UNAUTHORIZED,
                "{listen} GET {path}: {body}"
            );
            let (status, _, _) = call(
                &router,
                request("GET", path, REMOTE, &[("authorization", "Bearer wrong")]),
            )
            .await;
            assert_eq!(
                status,
                StatusCode::UNAUTHORIZED,
                "{listen} GET {path} with a wrong token"
            );
        }
        // The page sends a browser to the login form, which is open.
        let (status, headers, _) = call(&router, request("GET", "/", REMOTE, &[])).await;
        assert!(status.is_redirection(), "{status}");
        assert_eq!(headers[header::LOCATION], "/login");
        let (status, _, body) = call(&router, request("GET", "/login", REMOTE, &[])).await;
        assert_eq!(status, StatusCode::OK);
        assert!(body.contains("type=\"password\""));
        // With the token, everything reads.
        let (status, _, body) = call(
            &router,
            request(
                "GET",
                "/api/campaigns",
                REMOTE,
                &[("authorization", BEARER)],
            ),
        )
        .await;
        assert_eq!(status, StatusCode::OK, "{body}");
        assert!(body.contains("\"camp\""));
    }
    let off = router(&coordinator, "0.0.0.0:8080").await;
    let (status, _, _) = call(&off, request("GET", "/api/campaigns", LOOPBACK, &[])).await;
    assert_eq!(
        status,
        StatusCode::UNAUTHORIZED,
        "a server listening off loopback trusts no peer's address"
    );
}

#[tokio::test]
async fn loopback_reads_freely_but_changes_nothing_without_the_token() {
    let dir = tempfile::tempdir().unwrap();
    let coordinator = coordinator(&dir, 5).await;
    let router = router(&coordinator, "127.0.0.1:8080").await;
    let (status, headers, body) = call(&router, request("GET", "/", LOOPBACK, &[])).await;
    assert_eq!(status, StatusCode::OK);
    assert!(
        headers[header::CONTENT_TYPE]
            .to_str()
            .unwrap()
            .starts_with("text/html")
    );
    assert!(body.contains("/page.js"), "{body}");
    let (status, _, body) = call(&router, request("GET", "/api/snapshot", LOOPBACK, &[])).await;
    assert_eq!(status, StatusCode::OK);
    let snapshot: serde_json::Value = serde_json::from_str(&body).unwrap();
    assert_eq!(snapshot["authenticated"], false);
    assert_eq!(snapshot["campaigns"][0]["status"]["queued"], 5);

    let before = coordinator.status(Some("camp")).await.unwrap();
    let cancel = "/api/campaigns/camp/cancel";
    for headers in [
        &[][..],
        &[("authorization", "Bearer wrong")][..],
        &[("cookie", "sweep_session=00")][..],
    ] {
        let (status, _, body) = call(&router, request("POST", cancel, LOOPBACK, headers)).await;
        assert_eq!(status, StatusCode::UNAUTHORIZED, "{headers:?}: {body}");
    }
    // A read method on the cancel route does nothing either.
    let (status, _, _) = call(&router, request("GET", cancel, LOOPBACK, &[])).await;
    assert_eq!(status, StatusCode::METHOD_NOT_ALLOWED);
    assert_eq!(
        coordinator.status(Some("camp")).await.unwrap(),
        before,
        "nothing changed"
    );
    assert_eq!(before.cancelled, 0);

    // The login form sets an HttpOnly, SameSite=Strict cookie that then authorises the cancel.
    let mut login = request(
        "POST",
        "/login",
        LOOPBACK,
        &[("content-type", "application/x-www-form-urlencoded")],
    );
    *login.body_mut() = Body::from(format!("token={TOKEN}"));
    let (status, headers, _) = call(&router, login).await;
    assert!(status.is_redirection(), "{status}");
    let cookie = headers[header::SET_COOKIE].to_str().unwrap().to_owned();
    assert!(
        cookie.contains("HttpOnly") && cookie.contains("SameSite=Strict"),
        "{cookie}"
    );
    assert!(
        !cookie.contains(TOKEN),
        "the cookie is not the token: {cookie}"
    );
    let session = cookie.split(';').next().unwrap().to_owned();
    let (status, _, body) = call(
        &router,
        request("POST", cancel, LOOPBACK, &[("cookie", &session)]),
    )
    .await;
    assert_eq!(status, StatusCode::OK, "{body}");
    let answer: serde_json::Value = serde_json::from_str(&body).unwrap();
    assert_eq!(answer["cancelled"], 5);
    assert_eq!(coordinator.status(Some("camp")).await.unwrap().cancelled, 5);

    // A wrong token at the form sets nothing.
    let mut login = request("POST", "/login", LOOPBACK, &[]);
    *login.body_mut() = Body::from("token=nope");
    let (status, headers, _) = call(&router, login).await;
    assert_eq!(status, StatusCode::UNAUTHORIZED);
    assert!(headers.get(header::SET_COOKIE).is_none());
}

#[tokio::test]
async fn failures_are_listed_with_their_worker_and_reason() {
    let dir = tempfile::tempdir().unwrap();
    let coordinator = coordinator(&dir, 2).await;
    coordinator.register(&worker("w1")).await.unwrap();
    for attempt in 1..=2 {
        let leases = coordinator.lease("w1", 1, true).await.unwrap();
        assert_eq!(leases.len(), 1);
        let l = &leases[0];
        coordinator
            .fail("w1", &l.job_id, l.token, &format!("boom {attempt}"))
            .await
            .unwrap();
    }
    let router = router(&coordinator, "127.0.0.1:8080").await;
    let (_, _, body) = call(&router, request("GET", "/api/failures", LOOPBACK, &[])).await;
    let failures: Vec<serde_json::Value> = serde_json::from_str(&body).unwrap();
    assert_eq!(failures.len(), 2, "{body}");
    assert_eq!(failures[0]["reason"], "boom 2", "newest first");
    assert_eq!(failures[0]["attempt"], 2);
    assert!(
        failures
            .iter()
            .all(|f| f["worker"] == "w1" && f["job_id"] == "job-000"),
        "{body}"
    );
    let (_, _, body) = call(&router, request("GET", "/api/workers", LOOPBACK, &[])).await;
    let workers: Vec<serde_json::Value> = serde_json::from_str(&body).unwrap();
    assert_eq!(workers[0]["id"], "w1");
    assert_eq!(workers[0]["cpu_model"], "Test CPU");
    assert_eq!(workers[0]["stale"], false);
    // The job failed twice (max_attempts 2): failed, and counted so.
    let (_, _, body) = call(&router, request("GET", "/api/campaigns", LOOPBACK, &[])).await;
    let campaigns: Vec<serde_json::Value> = serde_json::from_str(&body).unwrap();
    assert_eq!(campaigns[0]["status"]["failed"], 1);
    assert_eq!(campaigns[0]["progress"], 0.5);
}

#[tokio::test]
async fn the_page_serves_https_with_the_given_certificate() {
    use rcgen::{CertificateParams, KeyPair};
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    use tokio_rustls::rustls;

    let dir = tempfile::tempdir().unwrap();
    let coordinator = coordinator(&dir, 1).await;
    let key = KeyPair::generate().unwrap();
    let cert = CertificateParams::new(vec!["localhost".to_string()])
        .unwrap()
        .self_signed(&key)
        .unwrap();
    let options = dashboard::Options {
        listen: "127.0.0.1:0".parse().unwrap(),
        token: Some(Token::new(TOKEN).unwrap()),
        tls: Some((cert.pem().into_bytes(), key.serialize_pem().into_bytes())),
    };
    let bound = dashboard::bind(options).await.unwrap();
    let url = bound.url().unwrap();
    assert!(url.starts_with("https://127.0.0.1:"), "{url}");
    let addr = url
        .trim_start_matches("https://")
        .trim_end_matches('/')
        .to_owned();
    let server = tokio::spawn(bound.serve(coordinator, std::future::pending()));

    let mut roots = rustls::RootCertStore::empty();
    roots.add(cert.der().clone()).unwrap();
    let config = rustls::ClientConfig::builder_with_provider(Arc::new(
        rustls::crypto::ring::default_provider(),
    ))
    .with_safe_default_protocol_versions()
    .unwrap()
    .with_root_certificates(roots)
    .with_no_client_auth();
    let connector = tokio_rustls::TlsConnector::from(Arc::new(config));
    let tcp = tokio::net::TcpStream::connect(&addr).await.unwrap();
    let name = rustls::pki_types::ServerName::try_from("localhost").unwrap();
    let mut tls = tokio::time::timeout(Duration::from_secs(10), connector.connect(name, tcp))
        .await
        .unwrap()
        .unwrap();
    tls.write_all(b"GET /api/campaigns HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n")
        .await
        .unwrap();
    let mut response = String::new();
    tokio::time::timeout(Duration::from_secs(10), tls.read_to_string(&mut response))
        .await
        .unwrap()
        .unwrap();
    assert!(response.starts_with("HTTP/1.1 200"), "{response}");
    assert!(response.contains("\"campaign\":\"camp\""), "{response}");
    // Plain HTTP to the HTTPS port gets no page.
    let mut plain = tokio::net::TcpStream::connect(&addr).await.unwrap();
    plain
        .write_all(b"GET / HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
        .await
        .unwrap();
    let mut answer = Vec::new();
    let _ = tokio::time::timeout(Duration::from_secs(10), plain.read_to_end(&mut answer)).await;
    assert!(!String::from_utf8_lossy(&answer).contains("200 OK"));
    server.abort();
}

#[tokio::test]
async fn an_address_off_loopback_without_a_token_is_refused() {
    let options = dashboard::Options {
        listen: "0.0.0.0:0".parse().unwrap(),
        token: None,
        tls: None,
    };
    let refused = dashboard::bind(options).await.err().expect("refused");
    assert!(refused.to_string().contains("without a token"), "{refused}");
}

/// Superquadric runs of Fig. 13 (p = 2 and 4 at X0 = 0.5 with LL, the paper's state point),
/// run by `jobs::run` and stored as a worker stores them.
async fn run_superquadrics(coordinator: &Coordinator) {
    let jobs: Vec<jobs::JobSpec> = [2.0, 4.0]
        .into_iter()
        .map(|p| {
            let scene = format!(
                "shape = \"superquadric\"\nexponents = [2.0, 2.0, {p}]\nn = 512\nphi = 0.256\n\
                 x0 = 0.5\nneighbours = \"ll\"\ncollisions = 500\nequilibrate = 0\n"
            );
            jobs::JobSpec::Edmd(edmd::Scene::from_toml_str(&scene).unwrap())
        })
        .collect();
    let new_jobs: Vec<NewJob> = jobs
        .iter()
        .map(|spec| NewJob {
            id: spec.id(),
            kind: spec.kind().into(),
            params_json: spec.canonical_json(),
            estimate_s: 1.0,
            exclusive: false,
            pass: 0,
            foreign_code: false,
        })
        .collect();
    let campaign = NewCampaign {
        id: "fig13".into(),
        name: "fig13".into(),
        plan_text: String::new(),
        searches: Vec::new(),
    };
    coordinator.submit(&campaign, &new_jobs).await.unwrap();
    coordinator.register(&worker("w-fig13")).await.unwrap();
    loop {
        let leases = coordinator.lease("w-fig13", 2, true).await.unwrap();
        if leases.is_empty() {
            break;
        }
        for lease in leases {
            let spec = jobs.iter().find(|s| s.id() == lease.job_id).unwrap();
            let records: Vec<String> = jobs::run(spec, 1)
                .unwrap()
                .into_iter()
                .map(|r| serde_json::Value::Object(r).to_string())
                .collect();
            coordinator
                .complete("w-fig13", &lease.job_id, lease.token, Some(0), &records)
                .await
                .unwrap();
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_page_draws_fig13_from_superquadric_runs() {
    for drawn in [true, false] {
        let dir = tempfile::tempdir().unwrap();
        let coordinator = coordinator(&dir, 0).await;
        if drawn {
            run_superquadrics(&coordinator).await;
        }
        let (router, _sampler) = dashboard::router(
            coordinator.clone(),
            "127.0.0.1:8080".parse().unwrap(),
            Some(Token::new(TOKEN).unwrap()),
            false,
        )
        .await
        .unwrap();
        let (status, headers, body) = call(
            &router,
            request("GET", "/api/figures/fig13.svg", LOOPBACK, &[]),
        )
        .await;
        if drawn {
            assert_eq!(status, StatusCode::OK, "{body}");
            assert_eq!(headers[header::CONTENT_TYPE], "image/svg+xml");
            assert!(
                body.starts_with("<svg") && body.contains("Fig. 13"),
                "{body}"
            );
        } else {
            assert_eq!(status, StatusCode::NOT_FOUND);
            assert!(
                body.contains("fig13 needs done edmd jobs (none yet)"),
                "{body}"
            );
        }
    }
}

/// A campaign's `[[tune]]` search is on the page while it runs: its state point, knob and goal,
/// the runs done out of its budget, and no conclusion yet.
#[tokio::test]
async fn a_running_search_is_shown() {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(dir.path().join("c.db")).await.unwrap();
    let coordinator = Coordinator::new(store, Config::default(), Arc::new(SystemClock)).unwrap();
    let plan = jobs::Plan::parse(
        "name = \"t\"\n[[tune]]\nfamily = \"edmd\"\nknob = \"delta_nnl\"\nrange = [0.05, 1.0]\n\
         goal = \"min tau_c_us\"\nmax_evaluations = 9\nshape = \"ellipsoid\"\nx0 = 2.0\nn = 64\n\
         phi = 0.3\nneighbours = \"nnl\"\ncollisions = 1000\n",
        "t.toml",
    )
    .unwrap();
    let search = &plan.tunes[0];
    let first = search.evaluation(0.2, 0);
    let campaign = NewCampaign {
        id: "camp".into(),
        name: "t".into(),
        plan_text: String::new(),
        searches: vec![serde_json::to_string(search).unwrap()],
    };
    let job = NewJob {
        id: first.id(),
        kind: first.kind().into(),
        params_json: first.canonical_json(),
        estimate_s: 1.0,
        exclusive: false,
        pass: 0,
        foreign_code: false,
    };
    coordinator.submit(&campaign, &[job]).await.unwrap();
    let router = router(&coordinator, "127.0.0.1:8080").await;
    let (_, _, body) = call(&router, request("GET", "/api/snapshot", LOOPBACK, &[])).await;
    let snapshot: serde_json::Value = serde_json::from_str(&body).unwrap();
    let searches = snapshot["searches"].as_array().expect("searches");
    assert_eq!(searches.len(), 1, "{body}");
    let s = &searches[0];
    assert_eq!(s["campaign"], "t");
    assert_eq!(s["knob"], "delta_nnl");
    assert_eq!(s["goal"]["field"], "tau_c_us");
    assert_eq!(
        (s["shape"].as_str(), s["x0"].as_f64()),
        (Some("ellipsoid"), Some(2.0))
    );
    assert_eq!(
        (s["evaluations"].as_u64(), s["max_evaluations"].as_u64()),
        (Some(0), Some(9))
    );
    assert!(s["conclusion"].is_null(), "running: {s}");
    let page = std::str::from_utf8(include_bytes!("../page/page.js")).unwrap();
    assert!(page.contains("renderSearches(snapshot)"));
}
