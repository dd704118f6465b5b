//! The mirror page's answer buttons (docs/monitor.md, "Answering from the
//! page"): `POST /answer` with `{"id": N, "choice": "yes"}` hands the
//! operator's answer to `petrel mirror`'s loop, which sends it exactly as
//! an answer typed on its stdin (the dialog checks it, the uplink signs it
//! with the operator key); `GET /answer` tells the page whether it may
//! answer, or why not. The page can send nothing else: the loop takes a
//! question id and a choice, nothing more.
//!
//! A field laptop's browser also runs other pages, and a page may send a
//! request to any address: an answer is taken only when
//! - it comes from this computer (a loopback peer): nobody else on the
//!   field's network answers, even with `--http 0.0.0.0:PORT`;
//! - it carries `Content-Type: application/json` and `X-Petrel-Answer: 1`:
//!   a browser sends neither from another site's page without asking first
//!   (a CORS preflight, which this server never grants);
//! - its `Host` is an IP address or `localhost` (a name resolving to
//!   127.0.0.1, "DNS rebinding", is refused) and its `Origin` and
//!   `Sec-Fetch-Site`, when the browser sends them, say the page is this
//!   server's own.

use std::net::SocketAddr;
use std::time::Duration;

use axum::extract::{ConnectInfo, State};
use axum::http::{HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use serde_json::json;
use tokio::sync::{mpsc, oneshot};

/// An answer from the page, for the mirror's loop; `reply` gets what was
/// done (the line the CLI says) or why not.
#[derive(Debug)]
pub struct Request {
    pub id: u64,
    pub choice: String,
    pub reply: oneshot::Sender<Result<String, String>>,
}

/// Where the page's answers go: the mirror's loop, when the operator key
/// is loaded.
#[derive(Clone, Debug)]
pub struct Desk {
    to: Result<mpsc::Sender<Request>, String>,
}

/// Answers waiting for the loop at most (a page asks one at a time).
const QUEUE: usize = 4;
/// How long the page waits for the loop to send.
const WAIT: Duration = Duration::from_secs(5);

impl Desk {
    /// A desk taking answers (the loop reads the receiver), or, with
    /// `Err(why)`, a read-only one saying why.
    pub fn new(answering: Result<(), String>) -> (Desk, Option<mpsc::Receiver<Request>>) {
        match answering {
            Ok(()) => {
                let (tx, rx) = mpsc::channel(QUEUE);
                (Desk { to: Ok(tx) }, Some(rx))
            }
            Err(why) => (Desk { to: Err(why) }, None),
        }
    }
}

/// `GET /answer` and `POST /answer`.
pub fn routes(desk: Desk) -> Router {
    Router::new()
        .route("/answer", get(can_answer).post(answer))
        .with_state(desk)
}

/// Whether this browser may answer: `{"can": bool, "why": text}`.
async fn can_answer(
    State(desk): State<Desk>,
    ConnectInfo(peer): ConnectInfo<SocketAddr>,
) -> Response {
    let why = match (&desk.to, peer.ip().is_loopback()) {
        (Err(why), _) => Some(why.clone()),
        (Ok(_), false) => Some(NOT_LOCAL.to_owned()),
        (Ok(_), true) => None,
    };
    axum::Json(json!({"can": why.is_none(), "why": why})).into_response()
}

const NOT_LOCAL: &str =
    "answers are taken from the mirror's own computer only (this page is read-only here)";

fn refuse(status: StatusCode, why: impl Into<String>) -> Response {
    (
        status,
        axum::Json(json!({"sent": false, "error": why.into()})),
    )
        .into_response()
}

/// Why a request is not one the served page made on this computer.
pub fn admit(peer: SocketAddr, headers: &HeaderMap) -> Result<(), String> {
    let header = |name: &str| headers.get(name).and_then(|v| v.to_str().ok());
    if !peer.ip().is_loopback() {
        return Err(NOT_LOCAL.into());
    }
    if header("x-petrel-answer") != Some("1") {
        return Err("not the monitor page's request (no X-Petrel-Answer)".into());
    }
    if !header("content-type").is_some_and(|c| c.starts_with("application/json")) {
        return Err("expected Content-Type: application/json".into());
    }
    let Some(host) = header("host") else {
        return Err("no Host".into());
    };
    super::guard::local_host(host)?;
    if let Some(origin) = header("origin") {
        if origin != format!("http://{host}") {
            return Err(format!("a page from {origin} may not answer"));
        }
    }
    if let Some(site) = header("sec-fetch-site") {
        if site != "same-origin" {
            return Err(format!("a {site} page may not answer"));
        }
    }
    Ok(())
}

async fn answer(
    State(desk): State<Desk>,
    ConnectInfo(peer): ConnectInfo<SocketAddr>,
    headers: HeaderMap,
    body: String,
) -> Response {
    let to = match &desk.to {
        Ok(to) => to,
        Err(why) => return refuse(StatusCode::FORBIDDEN, why.clone()),
    };
    if let Err(why) = admit(peer, &headers) {
        tracing::warn!("an answer from {peer} refused: {why}");
        return refuse(StatusCode::FORBIDDEN, why);
    }
    let asked: serde_json::Value = match serde_json::from_str(&body) {
        Ok(v) => v,
        Err(e) => return refuse(StatusCode::BAD_REQUEST, format!("not JSON: {e}")),
    };
    let (Some(id), Some(choice)) = (asked["id"].as_u64(), asked["choice"].as_str()) else {
        return refuse(
            StatusCode::BAD_REQUEST,
            "expected {\"id\": QUESTION, \"choice\": CHOICE}",
        );
    };
    let (reply, replied) = oneshot::channel();
    let request = Request {
        id,
        choice: choice.to_owned(),
        reply,
    };
    if to.try_send(request).is_err() {
        return refuse(
            StatusCode::SERVICE_UNAVAILABLE,
            "the mirror is busy with other answers",
        );
    }
    match tokio::time::timeout(WAIT, replied).await {
        Ok(Ok(Ok(said))) => axum::Json(json!({"sent": true, "said": said})).into_response(),
        Ok(Ok(Err(why))) => refuse(StatusCode::CONFLICT, why),
        _ => refuse(
            StatusCode::SERVICE_UNAVAILABLE,
            "the mirror did not take the answer",
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::http::HeaderValue;

    fn page_headers(host: &str) -> HeaderMap {
        let mut h = HeaderMap::new();
        h.insert("x-petrel-answer", HeaderValue::from_static("1"));
        h.insert("content-type", HeaderValue::from_static("application/json"));
        h.insert(
            "host",
            HeaderValue::from_str(host).unwrap_or_else(|e| panic!("{e}")),
        );
        h.insert(
            "origin",
            HeaderValue::from_str(&format!("http://{host}")).unwrap_or_else(|e| panic!("{e}")),
        );
        h.insert("sec-fetch-site", HeaderValue::from_static("same-origin"));
        h
    }

    fn at(addr: &str) -> SocketAddr {
        addr.parse().unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn the_served_page_on_this_computer_is_admitted() {
        for host in [
            "127.0.0.1:8090",
            "localhost:8090",
            "[::1]:8090",
            "10.0.0.5:80",
        ] {
            assert_eq!(admit(at("127.0.0.1:5000"), &page_headers(host)), Ok(()));
        }
        assert_eq!(admit(at("[::1]:5000"), &page_headers("[::1]:8090")), Ok(()));
    }

    #[test]
    fn other_computers_sites_and_names_are_refused() {
        let ok = page_headers("127.0.0.1:8090");
        assert!(
            admit(at("192.168.1.20:5000"), &ok).is_err(),
            "another computer"
        );
        let mut h = ok.clone();
        h.remove("x-petrel-answer");
        assert!(
            admit(at("127.0.0.1:5000"), &h).is_err(),
            "a plain form post"
        );
        let mut h = ok.clone();
        h.insert("content-type", HeaderValue::from_static("text/plain"));
        assert!(admit(at("127.0.0.1:5000"), &h).is_err(), "a simple request");
        let mut h = ok.clone();
        h.insert("origin", HeaderValue::from_static("http://evil.example"));
        assert!(admit(at("127.0.0.1:5000"), &h).is_err(), "another site");
        let mut h = ok.clone();
        h.insert("sec-fetch-site", HeaderValue::from_static("cross-site"));
        assert!(admit(at("127.0.0.1:5000"), &h).is_err(), "cross-site");
        let h = page_headers("evil.example:8090");
        assert!(admit(at("127.0.0.1:5000"), &h).is_err(), "DNS rebinding");
        let mut h = ok;
        h.remove("host");
        assert!(admit(at("127.0.0.1:5000"), &h).is_err());
    }
}
