//! Who may talk to Petrel's web pages (docs/reliability.md, "The web
//! pages"): one rule in front of every route of every page — `run`,
//! `demo`, `view`, `mirror` and `edit` — so that a page served on this
//! computer answers only itself.
//!
//! A field laptop's browser runs other sites' pages too, and any of them
//! may send requests to `127.0.0.1`, or, after DNS rebinding, to a name of
//! its own that resolves to this computer. A request is answered only when
//! - its `Host` is an IP address or `localhost` (a rebound name is not);
//! - its `Origin`, when the browser sends one (every WebSocket, every
//!   POST, every script's `fetch`), is this server's own: browsers apply
//!   no CORS to WebSockets, so the live frames were readable by any page;
//! - its `Sec-Fetch-Site`, when sent, says the same site or none (typed
//!   in the address bar), except for a link followed to the page itself
//!   (a top-level navigation, harmless: the other site cannot read it).
//!
//! Every answer forbids framing by another page (clickjacking the editor).
//! Bodies and WebSocket messages are bounded: the page only ever sends a
//! small JSON object, so nothing from outside makes the server hold more
//! than a few KiB per connection, and WebSockets are few at a time.

use std::sync::Arc;

use axum::extract::Request;
use axum::http::{header, HeaderMap, HeaderValue, Method, StatusCode};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use tokio::sync::{OwnedSemaphorePermit, Semaphore};

/// The largest request body taken (an edit, an answer: a few hundred
/// bytes; a project's whole nets are never sent up).
pub const BODY_LIMIT: usize = 64 * 1024;

/// The largest WebSocket message or frame taken from a browser (the page
/// sends `{"at": µs, "step": 1}`).
pub const MESSAGE_LIMIT: usize = 4 * 1024;

/// WebSockets open at once on one server; one more is answered 503.
pub const SOCKETS: usize = 16;

/// Why a request is not one this server's own page made: `Err((status,
/// reason))`.
pub fn admit(method: &Method, headers: &HeaderMap) -> Result<(), (StatusCode, String)> {
    let text = |name: &str| headers.get(name).and_then(|v| v.to_str().ok());
    let Some(host) = text("host") else {
        return Err((StatusCode::BAD_REQUEST, "no Host".into()));
    };
    local_host(host).map_err(|why| (StatusCode::MISDIRECTED_REQUEST, why))?;
    if let Some(origin) = headers.get(header::ORIGIN) {
        let origin = origin.to_str().unwrap_or("");
        if origin != format!("http://{host}") {
            return Err((
                StatusCode::FORBIDDEN,
                format!("a page from {origin} may not use this page's server"),
            ));
        }
    }
    match text("sec-fetch-site") {
        None | Some("same-origin") | Some("none") => Ok(()),
        Some(site) => {
            let navigation = method == Method::GET
                && text("sec-fetch-mode") == Some("navigate")
                && text("sec-fetch-dest").is_none_or(|d| d == "document");
            if navigation {
                Ok(())
            } else {
                Err((
                    StatusCode::FORBIDDEN,
                    format!("a {site} page may not use this page's server"),
                ))
            }
        }
    }
}

/// Whether `host` (a `Host` header) names this computer by address: an IP
/// literal (v4, or v6 in brackets) or `localhost`, with or without a port.
pub fn local_host(host: &str) -> Result<(), String> {
    let name = match host.rsplit_once(':') {
        Some((name, port)) if port.parse::<u16>().is_ok() => name,
        _ => host,
    };
    let name = name
        .strip_prefix('[')
        .and_then(|n| n.strip_suffix(']'))
        .unwrap_or(name);
    if name.eq_ignore_ascii_case("localhost") || name.parse::<std::net::IpAddr>().is_ok() {
        Ok(())
    } else {
        Err(format!(
            "Host {host} is not an address of this computer: open the page by its IP address (http://127.0.0.1:PORT/, or the computer's address on the field's network)"
        ))
    }
}

/// The middleware in front of every page's routes (`Server::serve`).
pub async fn guard(request: Request, next: Next) -> Response {
    if let Err((status, why)) = admit(request.method(), request.headers()) {
        tracing::warn!(
            "web: {} {} refused: {why}",
            request.method(),
            request.uri().path()
        );
        let mut refused = (status, why).into_response();
        framed_by_nobody(refused.headers_mut());
        return refused;
    }
    let mut response = next.run(request).await;
    framed_by_nobody(response.headers_mut());
    response
}

fn framed_by_nobody(headers: &mut HeaderMap) {
    headers.insert(header::X_FRAME_OPTIONS, HeaderValue::from_static("DENY"));
    headers.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static("frame-ancestors 'none'"),
    );
    headers.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
}

/// The WebSockets a server holds open: a permit each, [`SOCKETS`] at most.
#[derive(Clone, Debug)]
pub struct Sockets(Arc<Semaphore>);

impl Default for Sockets {
    fn default() -> Self {
        Sockets(Arc::new(Semaphore::new(SOCKETS)))
    }
}

impl Sockets {
    /// A place for one more WebSocket, held as long as it is open; none
    /// when all are taken.
    pub fn take(&self) -> Option<OwnedSemaphorePermit> {
        self.0.clone().try_acquire_owned().ok()
    }
}

/// The answer for a browser that finds every WebSocket taken.
pub fn sockets_full() -> Response {
    tracing::warn!("web: a WebSocket refused: {SOCKETS} already open");
    (
        StatusCode::SERVICE_UNAVAILABLE,
        format!("{SOCKETS} pages already follow this server: close one"),
    )
        .into_response()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn headers(pairs: &[(&'static str, &str)]) -> HeaderMap {
        let mut h = HeaderMap::new();
        for (name, value) in pairs {
            h.insert(
                *name,
                HeaderValue::from_str(value).unwrap_or_else(|e| panic!("{e}")),
            );
        }
        h
    }

    #[test]
    fn the_page_and_tools_on_this_computer_are_admitted() {
        for host in [
            "127.0.0.1:8090",
            "localhost:8090",
            "LOCALHOST",
            "[::1]:8090",
            "10.0.0.5:80",
            "127.0.0.1",
        ] {
            // A tool (curl, a test) sends no Origin.
            assert_eq!(admit(&Method::GET, &headers(&[("host", host)])), Ok(()));
            let own = format!("http://{host}");
            let page = headers(&[
                ("host", host),
                ("origin", &own),
                ("sec-fetch-site", "same-origin"),
            ]);
            assert_eq!(admit(&Method::POST, &page), Ok(()), "{host}");
        }
        // Typed in the address bar; a link followed from another site.
        let typed = headers(&[("host", "127.0.0.1:1"), ("sec-fetch-site", "none")]);
        assert_eq!(admit(&Method::GET, &typed), Ok(()));
        let link = headers(&[
            ("host", "127.0.0.1:1"),
            ("sec-fetch-site", "cross-site"),
            ("sec-fetch-mode", "navigate"),
            ("sec-fetch-dest", "document"),
        ]);
        assert_eq!(admit(&Method::GET, &link), Ok(()));
    }

    #[test]
    fn rebound_names_other_sites_and_frames_are_refused() {
        let refused = |method: Method, pairs: &[(&'static str, &str)]| {
            admit(&method, &headers(pairs)).map_err(|(status, _)| status)
        };
        // DNS rebinding: Origin and Host agree, but name another site.
        assert_eq!(
            refused(
                Method::POST,
                &[
                    ("host", "evil.example:8091"),
                    ("origin", "http://evil.example:8091")
                ]
            ),
            Err(StatusCode::MISDIRECTED_REQUEST)
        );
        assert_eq!(
            refused(Method::GET, &[("host", "127.0.0.1.evil.example")]),
            Err(StatusCode::MISDIRECTED_REQUEST)
        );
        assert_eq!(refused(Method::GET, &[]), Err(StatusCode::BAD_REQUEST));
        // Another site's page opening the live WebSocket.
        assert_eq!(
            refused(
                Method::GET,
                &[
                    ("host", "127.0.0.1:8080"),
                    ("origin", "http://evil.example")
                ]
            ),
            Err(StatusCode::FORBIDDEN)
        );
        // Same host, another port: another origin.
        assert_eq!(
            refused(
                Method::GET,
                &[("host", "127.0.0.1:8080"), ("origin", "http://127.0.0.1:9")]
            ),
            Err(StatusCode::FORBIDDEN)
        );
        assert_eq!(
            refused(
                Method::GET,
                &[("host", "127.0.0.1:8080"), ("origin", "null")]
            ),
            Err(StatusCode::FORBIDDEN)
        );
        // Another site's script or frame (no Origin on a no-cors GET).
        for dest in ["script", "iframe", "empty"] {
            let mode = if dest == "iframe" {
                "navigate"
            } else {
                "no-cors"
            };
            assert_eq!(
                refused(
                    Method::GET,
                    &[
                        ("host", "127.0.0.1:8080"),
                        ("sec-fetch-site", "cross-site"),
                        ("sec-fetch-mode", mode),
                        ("sec-fetch-dest", dest),
                    ]
                ),
                Err(StatusCode::FORBIDDEN),
                "{dest}"
            );
        }
        assert_eq!(
            refused(
                Method::POST,
                &[
                    ("host", "127.0.0.1:8080"),
                    ("sec-fetch-site", "same-site"),
                    ("sec-fetch-mode", "navigate"),
                ]
            ),
            Err(StatusCode::FORBIDDEN),
            "a form posted from a sibling site"
        );
    }

    #[test]
    fn sockets_are_bounded_and_given_back() {
        let sockets = Sockets::default();
        let held: Vec<_> = (0..SOCKETS).filter_map(|_| sockets.take()).collect();
        assert_eq!(held.len(), SOCKETS);
        assert!(sockets.take().is_none());
        drop(held);
        assert!(sockets.take().is_some());
    }
}
