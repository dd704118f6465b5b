//! The web server: a thin axum router over a board owned elsewhere (the
//! live one, or a recording's index). Read-only: GET routes and a
//! WebSocket that sends frames; the mirror's page adds its answer desk
//! (`answer.rs`), the only route that changes anything. Every route of
//! every page served here (`petrel edit`'s too) is behind `guard.rs`. It
//! runs on its own thread and runtime, so serving pages never takes the
//! gateway loop's thread.

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Query, State};
use axum::http::header;
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use serde_json::Value as Json;

use super::guard::{self, Sockets};
use super::history::History;
use super::live::{Cursor, Live};

/// At most this many frames a second to one browser.
pub const FRAME_RATE: u64 = 30;

/// What the page shows.
#[derive(Clone)]
pub enum Source {
    Live(Arc<Live>),
    Recording(Arc<History>),
}

impl Source {
    /// The page: a recording's version `v` (0 the first), the live one's
    /// as it stands.
    fn page(&self, v: usize) -> String {
        match self {
            Source::Live(l) => l.page(),
            Source::Recording(h) => h.page(v),
        }
    }
}

/// `/page.json?v=N`: the version of a recording's page.
#[derive(serde::Deserialize)]
struct PageQuery {
    v: Option<usize>,
}

pub(crate) const INDEX: &str = include_str!("assets/index.html");
pub(crate) const SCRIPT: &str = include_str!("assets/monitor.js");
pub(crate) const STYLE: &str = include_str!("assets/monitor.css");

pub(crate) fn asset(kind: &'static str, body: &'static str) -> Response {
    ([(header::CONTENT_TYPE, kind)], body).into_response()
}

/// The page and its script and style, which the editing page serves too
/// (its own assets beside them).
pub(crate) fn page_routes<S: Clone + Send + Sync + 'static>() -> Router<S> {
    Router::new()
        .route(
            "/",
            get(|| async { asset("text/html; charset=utf-8", INDEX) }),
        )
        .route(
            "/monitor.js",
            get(|| async { asset("text/javascript; charset=utf-8", SCRIPT) }),
        )
        .route(
            "/monitor.css",
            get(|| async { asset("text/css; charset=utf-8", STYLE) }),
        )
        .route(
            "/favicon.ico",
            get(|| async { axum::http::StatusCode::NO_CONTENT }),
        )
}

/// What the routes share: the page's source and the WebSockets open.
#[derive(Clone)]
struct Shared {
    source: Source,
    sockets: Sockets,
}

/// The monitor's routes over `source` (the page, its assets, the nets,
/// the WebSocket). Served through [`Server::serve`], which puts the guard
/// in front of them.
pub fn router(source: Source) -> Router {
    let shared = Shared {
        source,
        sockets: Sockets::default(),
    };
    page_routes()
        .route(
            "/page.json",
            get(
                |State(s): State<Shared>, Query(q): Query<PageQuery>| async move {
                    (
                        [(header::CONTENT_TYPE, "application/json")],
                        s.source.page(q.v.unwrap_or(0)),
                    )
                },
            ),
        )
        .route("/ws", get(socket))
        .with_state(shared)
}

/// `GET /ws`: the page's WebSocket, while fewer than `guard::SOCKETS` are
/// open, taking only messages of a few KiB.
async fn socket(State(s): State<Shared>, ws: WebSocketUpgrade) -> Response {
    let Some(permit) = s.sockets.take() else {
        return guard::sockets_full();
    };
    ws.max_message_size(guard::MESSAGE_LIMIT)
        .max_frame_size(guard::MESSAGE_LIMIT)
        .on_upgrade(move |socket| async move {
            let _open = permit;
            match s.source {
                Source::Live(live) => live_socket(socket, live).await,
                Source::Recording(h) => recording_socket(socket, h).await,
            }
        })
}

async fn send(socket: &mut WebSocket, frame: Json) -> bool {
    socket
        .send(Message::Text(frame.to_string().into()))
        .await
        .is_ok()
}

/// A browser on the live board: the latest state when it changed, at most
/// `FRAME_RATE` a second; what happened in between is coalesced.
async fn live_socket(mut socket: WebSocket, live: Arc<Live>) {
    let mut version = live.subscribe();
    let mut cursor = Cursor::default();
    let interval = Duration::from_millis(1000 / FRAME_RATE);
    loop {
        version.borrow_and_update();
        if !send(&mut socket, live.frame(&mut cursor)).await {
            return;
        }
        let pause = tokio::time::sleep(interval);
        tokio::pin!(pause);
        // Wait out the frame interval, then for a change; the browser's
        // messages are read meanwhile (a close ends the task).
        let mut paused = false;
        loop {
            tokio::select! {
                _ = &mut pause, if !paused => paused = true,
                changed = version.changed(), if paused => {
                    if changed.is_err() {
                        return;
                    }
                    break;
                }
                message = socket.recv() => match message {
                    Some(Ok(Message::Close(_))) | None | Some(Err(_)) => return,
                    Some(Ok(_)) => {}
                },
            }
        }
    }
}

/// A browser over a recording: it asks for an instant (`{"at": µs}`, or
/// with `"step": 1 | -1` the next or previous moment something changed),
/// and gets the state then.
async fn recording_socket(mut socket: WebSocket, history: Arc<History>) {
    if !send(&mut socket, history.frame_at(history.start)).await {
        return;
    }
    while let Some(Ok(message)) = socket.recv().await {
        let Message::Text(text) = message else {
            if matches!(message, Message::Close(_)) {
                return;
            }
            continue;
        };
        let Ok(ask) = serde_json::from_str::<Json>(&text) else {
            continue;
        };
        let Some(at) = ask["at"].as_u64() else {
            continue;
        };
        let at = match ask["step"].as_i64() {
            Some(dir) => history.moment(at, dir),
            None => at,
        };
        if !send(&mut socket, history.frame_at(at)).await {
            return;
        }
    }
}

/// A server running on its own thread; stopped when dropped.
pub struct Server {
    pub address: SocketAddr,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Server {
    /// Serves `source` on `address` (bound before this returns).
    pub fn start(address: SocketAddr, source: Source) -> std::io::Result<Server> {
        Server::serve(address, router(source))
    }

    /// Serves the mirror's live board with its answer desk.
    pub fn start_mirror(
        address: SocketAddr,
        live: Arc<Live>,
        desk: super::answer::Desk,
    ) -> std::io::Result<Server> {
        Server::serve(
            address,
            router(Source::Live(live)).merge(super::answer::routes(desk)),
        )
    }

    /// Serves `app` on `address` (also `petrel edit`'s routes), behind
    /// `guard.rs`: this computer's own page only, bodies bounded.
    pub fn serve(address: SocketAddr, app: Router) -> std::io::Result<Server> {
        let app = app
            .layer(axum::extract::DefaultBodyLimit::max(guard::BODY_LIMIT))
            .layer(axum::middleware::from_fn(guard::guard));
        let listener = std::net::TcpListener::bind(address)?;
        listener.set_nonblocking(true)?;
        let address = listener.local_addr()?;
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()?;
        let thread = std::thread::Builder::new()
            .name("petrel-monitor".into())
            .spawn(move || {
                // A page can wait: never at a real-time priority a crew gave
                // the gateway (docs/run.md "On a busy computer").
                crate::thread_started();
                runtime.block_on(async move {
                    let listener = match tokio::net::TcpListener::from_std(listener) {
                        Ok(l) => l,
                        Err(e) => {
                            tracing::warn!("monitor: {e}");
                            return;
                        }
                    };
                    // The peer's address: the answer desk takes answers
                    // from this computer only.
                    let app = app.into_make_service_with_connect_info::<SocketAddr>();
                    let serve = axum::serve(listener, app).with_graceful_shutdown(async move {
                        let _ = stopped.await;
                    });
                    if let Err(e) = serve.await {
                        tracing::warn!("monitor: {e}");
                    }
                });
            })?;
        Ok(Server {
            address,
            stop: Some(stop),
            thread: Some(thread),
        })
    }

    /// Serves until the process ends (`petrel view`).
    pub fn wait(mut self) {
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        // Open WebSockets do not hold the graceful shutdown for long: the
        // thread is left to end with the process if they do.
        if let Some(t) = self.thread.take() {
            let deadline = std::time::Instant::now() + Duration::from_secs(1);
            while !t.is_finished() && std::time::Instant::now() < deadline {
                std::thread::sleep(Duration::from_millis(10));
            }
            if t.is_finished() {
                let _ = t.join();
            }
        }
    }
}
