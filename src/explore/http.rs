//! The explorer's HTTP side: binding, the token, size limits, routing, and turning each
//! view's result or error into a response. One line on standard error per refused
//! request; nothing else is logged.

use super::query::Query;
use super::views::{self, Base};
use super::work::Work;
use jeffcott_analysis::backend::Engine;
use jeffcott_analysis::output;
use jeffcott_core::error::{Error, Result};
use jeffcott_core::model::{COORD_NAMES, COORD_UNITS, Params};
use serde_json::json;
use std::io::Read;
use std::net::{IpAddr, SocketAddr};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Bytes of a request's URL at most.
pub const MAX_URL: usize = 8 * 1024;
/// Bytes of a request's body at most: a saved view's data.
pub const MAX_BODY: usize = 64 << 20;
/// Requests handled at once at most; more are refused with 503 until one ends.
pub const MAX_IN_FLIGHT: usize = 64;

const INDEX: &str = include_str!("page/index.html");
const APP: &str = include_str!("page/app.js");
const STYLE: &str = include_str!("page/style.css");

/// How the explorer serves.
pub struct ExplorerConfig {
    /// The address to bind (loopback unless the user gave a host).
    pub host: IpAddr,
    /// The port (0: any free port).
    pub port: u16,
    /// Whether every API request must carry the token (a host was given).
    pub require_token: bool,
    /// The parameters, stepper and precision requests start from.
    pub base: Base,
    /// The engine every request runs on (opened once: a GPU's device and pipelines
    /// are set up at start).
    pub engine: Engine,
    /// The directory saved views go to.
    pub out: PathBuf,
}

/// A running explorer server.
pub struct Explorer {
    server: tiny_http::Server,
    state: Arc<State>,
    addr: SocketAddr,
}

struct State {
    base: Base,
    engine: Engine,
    token: Option<String>,
    work: Work,
    out: PathBuf,
    in_flight: AtomicUsize,
    /// The Host headers a loopback server answers (DNS rebinding would send another).
    hosts: Option<Vec<String>>,
}

impl Explorer {
    /// Binds the address and opens the server; errors name `host` or `port`.
    pub fn start(cfg: ExplorerConfig) -> Result<Explorer> {
        let server = tiny_http::Server::http(SocketAddr::new(cfg.host, cfg.port)).map_err(|e| {
            Error::invalid(
                "port",
                cfg.port,
                format!("cannot listen on {}: {e}", cfg.host),
            )
        })?;
        let addr = server
            .server_addr()
            .to_ip()
            .ok_or_else(|| Error::invalid("host", cfg.host, "not an IP address"))?;
        let token = cfg.require_token.then(new_token).transpose()?;
        let hosts = cfg.host.is_loopback().then(|| {
            let p = addr.port();
            vec![
                format!("127.0.0.1:{p}"),
                format!("localhost:{p}"),
                format!("[::1]:{p}"),
            ]
        });
        Ok(Explorer {
            server,
            addr,
            state: Arc::new(State {
                base: cfg.base,
                engine: cfg.engine,
                token,
                work: Work::default(),
                out: cfg.out,
                in_flight: AtomicUsize::new(0),
                hosts,
            }),
        })
    }

    /// The bound address.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The page's URL, with the token when one is required.
    pub fn url(&self) -> String {
        let host = match self.addr.ip() {
            IpAddr::V4(ip) if ip.is_unspecified() => "127.0.0.1".to_string(),
            IpAddr::V6(ip) => format!("[{ip}]"),
            ip => ip.to_string(),
        };
        match &self.state.token {
            Some(t) => format!("http://{host}:{}/?token={t}", self.addr.port()),
            None => format!("http://{host}:{}/", self.addr.port()),
        }
    }

    /// The token every API request must carry, when one is required.
    pub fn token(&self) -> Option<&str> {
        self.state.token.as_deref()
    }

    /// Serves requests until [`Explorer::stop`] (from another thread) or an error of the
    /// listening socket. Each request runs on a thread of its own.
    pub fn serve(&self) {
        while let Ok(req) = self.server.recv() {
            let state = self.state.clone();
            if state.in_flight.fetch_add(1, Ordering::SeqCst) >= MAX_IN_FLIGHT {
                state.in_flight.fetch_sub(1, Ordering::SeqCst);
                refuse(req, 503, "too many requests at once; try again");
                continue;
            }
            std::thread::spawn(move || {
                handle(&state, req);
                state.in_flight.fetch_sub(1, Ordering::SeqCst);
            });
        }
    }

    /// Stops [`Explorer::serve`]; requests at work finish.
    pub fn stop(&self) {
        self.server.unblock();
    }
}

/// 128 random bits as hex, from the operating system's generator.
fn new_token() -> Result<String> {
    let mut b = [0u8; 16];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut b))
        .map_err(|e| Error::Io {
            path: "/dev/urandom".into(),
            source: e,
        })?;
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}

fn header(name: &str, value: &str) -> tiny_http::Header {
    tiny_http::Header::from_bytes(name.as_bytes(), value.as_bytes()).expect("valid header")
}

fn respond(req: tiny_http::Request, status: u16, kind: &str, body: Vec<u8>) {
    let r = tiny_http::Response::from_data(body)
        .with_status_code(status)
        .with_header(header("Content-Type", kind))
        .with_header(header("Cache-Control", "no-store"))
        .with_header(header("X-Content-Type-Options", "nosniff"));
    // A page gone before its answer is no error of the server's.
    let _ = req.respond(r);
}

fn respond_json(req: tiny_http::Request, status: u16, v: &serde_json::Value) {
    respond(req, status, "application/json", v.to_string().into_bytes());
}

/// Refuses a request with `status` and a message the page shows, logging one line.
fn refuse(req: tiny_http::Request, status: u16, message: &str) {
    let url: String = req.url().chars().take(120).collect();
    eprintln!("explore: {status} {} {url}: {message}", req.method());
    respond_json(req, status, &json!({ "error": message }));
}

fn handle(state: &State, req: tiny_http::Request) {
    if req.url().len() > MAX_URL {
        return refuse(
            req,
            414,
            &format!("the request's URL is longer than {MAX_URL} bytes"),
        );
    }
    if req.body_length().unwrap_or(0) > MAX_BODY {
        return refuse(
            req,
            413,
            &format!("the request's body is larger than {MAX_BODY} bytes"),
        );
    }
    if let Some(hosts) = &state.hosts {
        let host = req
            .headers()
            .iter()
            .find(|h| h.field.equiv("Host"))
            .map(|h| h.value.as_str().to_string());
        if !host.is_some_and(|h| hosts.contains(&h)) {
            return refuse(
                req,
                403,
                "this server answers only requests to its loopback address",
            );
        }
    }
    let (path, text) = match req.url().split_once('?') {
        Some((p, q)) => (p.to_string(), q.to_string()),
        None => (req.url().to_string(), String::new()),
    };
    match path.as_str() {
        "/" | "/index.html" => return respond(req, 200, "text/html; charset=utf-8", INDEX.into()),
        "/app.js" => return respond(req, 200, "text/javascript; charset=utf-8", APP.into()),
        "/style.css" => return respond(req, 200, "text/css; charset=utf-8", STYLE.into()),
        p if !p.starts_with("/api/") => return refuse(req, 404, "no such page"),
        _ => {}
    }
    let q = match Query::parse(&text) {
        Ok(q) => q,
        Err(e) => return refuse(req, 400, &e.to_string()),
    };
    if let Some(t) = &state.token {
        let given = q.get("token").map(str::to_string).or_else(|| {
            req.headers()
                .iter()
                .find(|h| h.field.equiv("X-Jeffcott-Token"))
                .map(|h| h.value.as_str().to_string())
        });
        if !given.is_some_and(|g| same(g.as_bytes(), t.as_bytes())) {
            return refuse(
                req,
                401,
                "this server needs the token it printed at start (?token=...)",
            );
        }
    }
    api(state, req, &path, &q);
}

/// Compares two secrets in time independent of where they differ.
fn same(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |d, (x, y)| d | (x ^ y)) == 0
}

/// The page's name for itself: 1 to 64 letters, digits, '-' or '_'.
fn tab(q: &Query) -> Result<&str> {
    let t = q.get("tab").unwrap_or("");
    let ok = (1..=64).contains(&t.len())
        && t.bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_');
    if ok {
        Ok(t)
    } else {
        Err(Error::invalid(
            "tab",
            t,
            "1 to 64 letters, digits, '-' or '_'",
        ))
    }
}

fn api(state: &State, req: tiny_http::Request, path: &str, q: &Query) {
    let view = match path {
        "/api/info" => return respond_json(req, 200, &info(state)),
        "/api/save" => return save(state, req, q),
        "/api/close" => {
            return match tab(q) {
                Ok(t) => respond_json(req, 200, &json!({"cancelled": state.work.close_tab(t)})),
                Err(e) => refuse(req, 400, &e.to_string()),
            };
        }
        "/api/bifurcation" | "/api/basin" | "/api/trajectory" => &path[5..],
        _ => return refuse(req, 404, "no such request"),
    };
    let t = match tab(q) {
        Ok(t) => t,
        Err(e) => return refuse(req, 400, &e.to_string()),
    };
    let claim = state.work.claim(t, view);
    let Some(slot) = state.work.slot(&claim.cancel) else {
        return respond_json(req, 409, &json!({"error": "cancelled by a newer request"}));
    };
    let (b, e, c) = (&state.base, &state.engine, &*claim.cancel);
    let result = slot.install(|| match view {
        "bifurcation" => views::bifurcation(e, b, q, c).map(|v| {
            let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
            (bytes, "application/octet-stream")
        }),
        "basin" => {
            views::basin(e, b, q, c).map(|v| (v.to_string().into_bytes(), "application/json"))
        }
        _ => views::trajectory(b, q, c).map(|v| (v.to_string().into_bytes(), "application/json")),
    });
    drop(slot);
    match result {
        Ok((body, kind)) => respond(req, 200, kind, body),
        Err(Error::Interrupted { .. }) => {
            respond_json(req, 409, &json!({"error": "cancelled by a newer request"}))
        }
        Err(e @ (Error::InvalidParameter { .. } | Error::Config { .. })) => {
            refuse(req, 400, &e.to_string())
        }
        Err(e) => refuse(req, 500, &e.to_string()),
    }
}

/// What the page needs to draw its forms: the parameters with symbols, units, defaults,
/// allowed ranges and the values requests start from; the coordinates; the backend.
fn info(state: &State) -> serde_json::Value {
    let params: Vec<serde_json::Value> = Params::info()
        .into_iter()
        .map(|i| {
            let mut v = serde_json::to_value(&i).expect("serializable");
            v["value"] = json!(state.base.params.get(i.name));
            v
        })
        .collect();
    let coords: Vec<_> = COORD_NAMES
        .iter()
        .zip(COORD_UNITS)
        .map(|(n, u)| json!({"name": n, "unit": u}))
        .collect();
    json!({
        "version": jeffcott_analysis::LONG_VERSION,
        "device": state.engine.device(),
        "precision": format!("{:?}", state.base.precision).to_lowercase(),
        "backend": format!("{:?}", state.base.backend).to_lowercase(),
        "params": params,
        "coords": coords,
        "limits": {
            "columns": views::MAX_COLUMNS, "starts": views::MAX_STARTS,
            "lanes": views::MAX_LANES, "basin_cells": views::MAX_BASIN_CELLS,
            "periods": views::MAX_PERIODS, "recorded": views::MAX_RECORDED,
        },
        "seed": views::SEED,
    })
}

/// Saves a view's data, sent as the request's body, into `--out` under a name the
/// server chooses (`<view>-<n>.<kind>`, n the first number free), with the command and
/// Python call that compute it at full resolution beside it (`<view>-<n>.txt`).
fn save(state: &State, mut req: tiny_http::Request, q: &Query) {
    let view = match q.text("view", "") {
        Ok(v @ ("bifurcation" | "basin" | "trajectory")) => v.to_string(),
        _ => return refuse(req, 400, "view: must be bifurcation, basin or trajectory"),
    };
    let kind = match q.text("kind", "") {
        Ok(k @ ("npy" | "png" | "json")) => k.to_string(),
        _ => return refuse(req, 400, "kind: must be npy, png or json"),
    };
    let mut body = Vec::new();
    let read = req
        .as_reader()
        .take(MAX_BODY as u64 + 1)
        .read_to_end(&mut body);
    if read.is_err() || body.len() > MAX_BODY {
        return refuse(
            req,
            413,
            &format!("the data must be at most {MAX_BODY} bytes"),
        );
    }
    let note = q.get("note").unwrap_or("");
    match write_saved(&state.out, &view, &kind, &body, note) {
        Ok(path) => respond_json(req, 200, &json!({ "saved": path })),
        Err(e) => refuse(req, 500, &e.to_string()),
    }
}

/// Writes `body` as the first free `<view>-<n>.<kind>` in `out` (created), and `note`
/// beside it; returns the path written.
fn write_saved(
    out: &std::path::Path,
    view: &str,
    kind: &str,
    body: &[u8],
    note: &str,
) -> Result<String> {
    let io = |path: &std::path::Path, e: std::io::Error| Error::Io {
        path: path.to_path_buf(),
        source: e,
    };
    std::fs::create_dir_all(out).map_err(|e| io(out, e))?;
    for n in 1..100_000u32 {
        let path = out.join(format!("{view}-{n}.{kind}"));
        // create_new: never overwrites what an earlier save (or another tab) wrote.
        match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&path)
        {
            Ok(reserved) => {
                // The name is reserved; the data replaces the empty reservation whole
                // (written beside it, renamed into place), and a failed write takes the
                // reservation away, so no file under a saved name is ever partial.
                drop(reserved);
                use std::io::Write;
                let written = output::write_atomically(&path, |w| w.write_all(body)).and_then(
                    |()| match note {
                        "" => Ok(()),
                        _ => output::write_atomically(
                            &path.with_extension(format!("{kind}.txt")),
                            |w| writeln!(w, "{note}"),
                        ),
                    },
                );
                if let Err(e) = written {
                    let _ = std::fs::remove_file(&path);
                    return Err(e);
                }
                return Ok(path.display().to_string());
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(io(&path, e)),
        }
    }
    Err(Error::invalid(
        "out",
        out.display(),
        "holds 100000 saved files of this view already",
    ))
}
