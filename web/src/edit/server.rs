//! The editing page's routes: the monitor's page and assets, the draft as
//! drawn (`/page.json`), its version (`/version`, polled by the page), and
//! the actions (`POST /edit`, `/undo`, `/redo`, `/reload`, `/stubs`), answered with
//! `{"ok": true}` or `{"ok": false, "error": "…", "conflict": bool}`.

use std::sync::Arc;

use axum::extract::State;
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::Router;
use serde_json::{json, Value as Json};

use super::op::Op;
use super::session::{Refusal, Session};
use crate::monitor::server::{asset, page_routes};

const EDIT_SCRIPT: &str = include_str!("../monitor/assets/edit.js");
const EDIT_STYLE: &str = include_str!("../monitor/assets/edit.css");

fn answer(status: StatusCode, body: Json) -> Response {
    (
        status,
        [(header::CONTENT_TYPE, "application/json")],
        body.to_string(),
    )
        .into_response()
}

fn refused(status: StatusCode, error: String, conflict: bool) -> Response {
    answer(
        status,
        json!({"ok": false, "error": error, "conflict": conflict}),
    )
}

/// A request another site's page could not have sent: JSON (a
/// cross-origin JSON POST needs a preflight, which this server never
/// grants) and, when the browser names its origin, this page's.
fn from_the_page(headers: &HeaderMap) -> bool {
    let text = |h: header::HeaderName| headers.get(h).and_then(|v| v.to_str().ok());
    let json = text(header::CONTENT_TYPE).is_some_and(|t| t.starts_with("application/json"));
    let same = match (text(header::ORIGIN), text(header::HOST)) {
        (None, _) => true,
        (Some(origin), Some(host)) => origin.strip_prefix("http://").is_some_and(|o| o == host),
        (Some(_), None) => false,
    };
    json && same
}

fn foreign() -> Response {
    refused(
        StatusCode::FORBIDDEN,
        "only the editor's page may change the project (a JSON request from its own origin)".into(),
        false,
    )
}

async fn edit(State(session): State<Arc<Session>>, headers: HeaderMap, body: String) -> Response {
    if !from_the_page(&headers) {
        return foreign();
    }
    let op: Op = match serde_json::from_str(&body) {
        Ok(op) => op,
        Err(e) => return refused(StatusCode::BAD_REQUEST, format!("not an edit: {e}"), false),
    };
    match session.apply(&op) {
        Ok(()) => answer(StatusCode::OK, json!({"ok": true})),
        Err(e) => refusal(e),
    }
}

fn refusal(e: Refusal) -> Response {
    match e {
        Refusal::Conflict(_) => refused(StatusCode::CONFLICT, e.to_string(), true),
        Refusal::Edit(_) | Refusal::NothingToUndo | Refusal::NothingToRedo => {
            refused(StatusCode::BAD_REQUEST, e.to_string(), false)
        }
        Refusal::Io(_) => refused(StatusCode::INTERNAL_SERVER_ERROR, e.to_string(), false),
    }
}

/// Undoes the session's last edit: `{"ok": true, "undone": "…"}`.
async fn undo(State(session): State<Arc<Session>>, headers: HeaderMap) -> Response {
    if !from_the_page(&headers) {
        return foreign();
    }
    match session.undo() {
        Ok(what) => answer(StatusCode::OK, json!({"ok": true, "undone": what})),
        Err(e) => refusal(e),
    }
}

/// Makes the last edit undone again: `{"ok": true, "redone": "…"}`.
async fn redo(State(session): State<Arc<Session>>, headers: HeaderMap) -> Response {
    if !from_the_page(&headers) {
        return foreign();
    }
    match session.redo() {
        Ok(what) => answer(StatusCode::OK, json!({"ok": true, "redone": what})),
        Err(e) => refusal(e),
    }
}

async fn stubs(State(session): State<Arc<Session>>, headers: HeaderMap, body: String) -> Response {
    if !from_the_page(&headers) {
        return foreign();
    }
    let ask: Json = serde_json::from_str(&body).unwrap_or_default();
    let lang = ask["lang"].as_str().unwrap_or("python");
    let out = ask["out"].as_str().unwrap_or("stubs");
    let force = ask["force"].as_bool().unwrap_or(false);
    match session.stubs(lang, out, force) {
        Ok(files) => answer(StatusCode::OK, json!({"ok": true, "files": files})),
        Err(e) => refused(StatusCode::BAD_REQUEST, e, false),
    }
}

/// The editing page's router over `session`.
pub fn router(session: Arc<Session>) -> Router {
    page_routes()
        .route(
            "/edit.js",
            get(|| async { asset("text/javascript; charset=utf-8", EDIT_SCRIPT) }),
        )
        .route(
            "/edit.css",
            get(|| async { asset("text/css; charset=utf-8", EDIT_STYLE) }),
        )
        .route(
            "/page.json",
            get(|State(s): State<Arc<Session>>| async move { answer(StatusCode::OK, s.page()) }),
        )
        .route(
            "/version",
            get(|State(s): State<Arc<Session>>| async move {
                answer(StatusCode::OK, json!({"version": s.version()}))
            }),
        )
        .route("/edit", post(edit))
        .route(
            "/reload",
            post(
                |State(s): State<Arc<Session>>, headers: HeaderMap| async move {
                    if !from_the_page(&headers) {
                        return foreign();
                    }
                    s.reload();
                    answer(StatusCode::OK, json!({"ok": true}))
                },
            ),
        )
        .route("/stubs", post(stubs))
        .route("/undo", post(undo))
        .route("/redo", post(redo))
        .with_state(session)
}
