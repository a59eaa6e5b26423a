//! The explorer's server, driven over real sockets: its slices equal the library's
//! ensembles, a newer request cancels the older, a closed tab stops its work, two tabs
//! at once get what they would alone, bad and oversized requests get a clear error and
//! the server lives on, loopback and the token guard it, saves stay inside --out.

use jeffcott::explore::views::{Base, SEED};
use jeffcott::explore::{Explorer, ExplorerConfig};
use jeffcott_analysis::backend::Engine;
use jeffcott_analysis::bifurcation::start_states;
use jeffcott_core::control::Control;
use jeffcott_core::ensemble::{Backend, EnsembleSpec, LaneSpec, Precision, cpu, range_value};
use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::{Params, STATE_DIM, X_R};
use std::io::{Read, Write};
use std::net::{IpAddr, Ipv4Addr, SocketAddr, TcpStream};
use std::sync::Arc;

struct Running {
    ex: Arc<Explorer>,
    out: tempfile::TempDir,
}

impl Drop for Running {
    fn drop(&mut self) {
        self.ex.stop();
    }
}

fn start(require_token: bool) -> Running {
    let out = tempfile::tempdir().unwrap();
    let ex = Arc::new(
        Explorer::start(ExplorerConfig {
            host: IpAddr::V4(Ipv4Addr::LOCALHOST),
            port: 0,
            require_token,
            base: Base {
                params: Params::default(),
                stepper: StepperConfig::DEFAULT,
                precision: Precision::F64,
                backend: Backend::Cpu,
            },
            engine: Engine::new(Backend::Cpu, Precision::F64).unwrap(),
            out: out.path().join("saved"),
        })
        .unwrap(),
    );
    let e = ex.clone();
    std::thread::spawn(move || e.serve());
    Running { ex, out }
}

/// Sends `raw` and returns the status and the body (de-chunked). `close`: the client
/// ends its side after the request, as a client that sends garbage and leaves.
fn send_with(addr: SocketAddr, raw: &[u8], close: bool) -> (u16, Vec<u8>) {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(std::time::Duration::from_secs(120)))
        .unwrap();
    s.write_all(raw).unwrap();
    if close {
        s.shutdown(std::net::Shutdown::Write).unwrap();
    }
    let mut buf = Vec::new();
    let _ = s.read_to_end(&mut buf);
    let at = buf
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .map_or(buf.len(), |i| i + 4);
    let head = String::from_utf8_lossy(&buf[..at]).to_ascii_lowercase();
    let status = head
        .split(' ')
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    let mut body = buf[at..].to_vec();
    if head.contains("transfer-encoding: chunked") {
        body = dechunk(&body);
    }
    (status, body)
}

fn send(addr: SocketAddr, raw: &[u8]) -> (u16, Vec<u8>) {
    send_with(addr, raw, false)
}

/// The data of a chunked body.
fn dechunk(mut b: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    loop {
        let eol = b
            .windows(2)
            .position(|w| w == b"\r\n")
            .expect("chunk size line");
        let size =
            usize::from_str_radix(std::str::from_utf8(&b[..eol]).unwrap().trim(), 16).unwrap();
        if size == 0 {
            return out;
        }
        out.extend_from_slice(&b[eol + 2..eol + 2 + size]);
        b = &b[eol + 4 + size..];
    }
}

fn get(addr: SocketAddr, path: &str) -> (u16, Vec<u8>) {
    get_as(addr, "127.0.0.1", "", path)
}

/// A GET with Host `host`:port and the extra header lines `headers` (each ending in
/// CRLF).
fn get_as(addr: SocketAddr, host: &str, headers: &str, path: &str) -> (u16, Vec<u8>) {
    let port = addr.port();
    let raw =
        format!("GET {path} HTTP/1.1\r\nHost: {host}:{port}\r\n{headers}Connection: close\r\n\r\n");
    send(addr, raw.as_bytes())
}

fn json(body: &[u8]) -> serde_json::Value {
    serde_json::from_slice(body).unwrap_or_else(|_| panic!("{}", String::from_utf8_lossy(body)))
}

#[test]
fn info_lists_every_parameter_with_symbol_unit_and_allowed_range() {
    let r = start(false);
    let (status, body) = get(r.ex.addr(), "/api/info");
    assert_eq!(status, 200);
    let v = json(&body);
    let params = v["params"].as_array().unwrap();
    assert_eq!(params.len(), Params::names().count());
    let delta = params.iter().find(|p| p["name"] == "delta").unwrap();
    assert_eq!(delta["unit"], "m");
    assert_eq!(delta["allowed"], "must be finite and > 0");
    assert_eq!(delta["value"], 0.006);
    assert_eq!(v["coords"].as_array().unwrap().len(), STATE_DIM);
    let (status, page) = get(r.ex.addr(), "/");
    assert_eq!(status, 200);
    assert!(String::from_utf8_lossy(&page).contains("app.js"));
}

#[test]
fn a_bifurcation_slice_is_the_ensemble_of_its_columns_bit_for_bit() {
    let r = start(false);
    let (n, k, transient, periods) = (5u32, 2u32, 30u32, 4u32);
    let path = format!(
        "/api/bifurcation?tab=t&lo=130&hi=134&n={n}&from=1&step=2&count=2&k={k}&coord=x_r&transient={transient}&periods={periods}&p.mu=0.1"
    );
    let (status, body) = get(r.ex.addr(), &path);
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&body));
    let got: Vec<f32> = body
        .chunks(4)
        .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
        .collect();
    // The same lanes through the library: columns 1 and 3, k seeded starts each.
    let p = Params {
        mu: 0.1,
        ..Params::default()
    };
    let mut lanes = Vec::new();
    for c in [1u64, 3] {
        for x0 in start_states(&p, k, 132.0, SEED) {
            lanes.push(LaneSpec {
                omega: range_value(130.0, 134.0, n as u64, c),
                x0,
                param_set: 0,
            });
        }
    }
    let spec = EnsembleSpec {
        param_sets: vec![p],
        lanes,
        transient,
        recorded: periods,
        stepper: StepperConfig::DEFAULT,
        precision: Precision::F64,
    };
    let res = cpu::run(&spec, false, Control::none()).unwrap();
    let want: Vec<f32> = res
        .poincare
        .chunks(STATE_DIM)
        .map(|x| x[X_R] as f32)
        .collect();
    assert_eq!(got.len(), want.len());
    assert!(
        got.iter()
            .zip(&want)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
}

#[test]
fn bad_values_name_the_field_and_the_server_lives_on() {
    let r = start(false);
    let a = r.ex.addr();
    for (path, field) in [
        ("/api/bifurcation?tab=t&lo=abc", "lo"),
        ("/api/bifurcation?tab=t&coord=z_q", "coord"),
        ("/api/bifurcation?tab=t&n=100000", "n"),
        ("/api/bifurcation?tab=t&lo=150&hi=140", "hi"),
        ("/api/bifurcation?tab=t&p.delta=-1", "delta"),
        ("/api/bifurcation?tab=t&p.nope=1", "nope"),
        ("/api/basin?tab=t&n=100000", "n"),
        ("/api/trajectory?tab=t&x0=1,2", "x0"),
        ("/api/bifurcation?tab=../x", "tab"),
        ("/api/bifurcation?tab=t&tab=u", "tab"),
    ] {
        let (status, body) = get(a, path);
        assert_eq!(status, 400, "{path}");
        let msg = json(&body)["error"].as_str().unwrap().to_string();
        assert!(msg.contains(field), "{path}: {msg}");
    }
    assert_eq!(get(a, "/api/nothing").0, 404);
    assert_eq!(get(a, "/../../etc/passwd").0, 404);
    let long = format!("/api/info?x={}", "a".repeat(9000));
    assert_eq!(get(a, &long).0, 414);
    let big = format!(
        "POST /api/save?tab=t&view=basin&kind=npy HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nContent-Length: 100000000\r\nConnection: close\r\n\r\n",
        a.port()
    );
    assert_eq!(send(a, big.as_bytes()).0, 413);
    let _ = send_with(a, b"NONSENSE\r\n\r\n", true);
    let _ = send_with(a, &[0xff; 300], true);
    assert_eq!(
        get(a, "/api/info").0,
        200,
        "the server outlives bad requests"
    );
}

/// A server with a long diagram request of page `tab` under way (given 300 ms to
/// start): the server (kept alive by the caller), its address and the request's thread.
fn long_request(
    tab: &'static str,
) -> (Running, SocketAddr, std::thread::JoinHandle<(u16, Vec<u8>)>) {
    let r = start(false);
    let a = r.ex.addr();
    let old = std::thread::spawn(move || get(a, &long_path(tab)));
    std::thread::sleep(std::time::Duration::from_millis(300));
    (r, a, old)
}

/// A request of many lanes over many periods: seconds of work on two cores.
fn long_path(tab: &str) -> String {
    format!("/api/bifurcation?tab={tab}&n=64&k=16&transient=3000&periods=8")
}

#[test]
fn a_newer_request_of_the_same_page_and_view_cancels_the_older() {
    let (_r, a, old) = long_request("same");
    let (status, _) = get(a, "/api/bifurcation?tab=same&n=2&k=1&transient=2&periods=2");
    assert_eq!(status, 200);
    let (old_status, body) = old.join().unwrap();
    assert_eq!(old_status, 409, "{}", String::from_utf8_lossy(&body));
}

#[test]
fn a_closed_page_stops_its_work() {
    let (_r, a, old) = long_request("gone");
    let (status, body) = get(a, "/api/close?tab=gone");
    assert_eq!(status, 200);
    assert_eq!(json(&body)["cancelled"], 1);
    assert_eq!(old.join().unwrap().0, 409);
}

#[test]
fn two_pages_at_once_each_get_what_they_would_alone() {
    let r = start(false);
    let a = r.ex.addr();
    let q = |tab: &str, lo: u32| {
        format!(
            "/api/bifurcation?tab={tab}&lo={lo}&hi={}&n=6&k=2&transient=40&periods=4",
            lo + 5
        )
    };
    let alone = [get(a, &q("one", 130)), get(a, &q("two", 136))];
    let (qa, qb) = (q("one", 130), q("two", 136));
    let ta = std::thread::spawn(move || get(a, &qa));
    let tb = std::thread::spawn(move || get(a, &qb));
    let together = [ta.join().unwrap(), tb.join().unwrap()];
    assert_eq!(alone[0].0, 200);
    assert_eq!(alone, together);
}

#[test]
fn a_basin_and_a_trajectory_answer_with_their_attractors() {
    let r = start(false);
    let a = r.ex.addr();
    let (status, body) = get(a, "/api/basin?tab=t&omega=133&n=4&transient=50&periods=8");
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&body));
    let b = json(&body);
    assert_eq!(b["labels"].as_array().unwrap().len(), 16);
    let fractions: f64 = b["attractors"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x["fraction"].as_f64().unwrap())
        .sum();
    let diverged = b["diverged_fraction"].as_f64().unwrap();
    assert!(
        (fractions + diverged - 1.0).abs() < 1e-9,
        "basin fractions sum to one"
    );
    let (status, body) = get(
        a,
        "/api/trajectory?tab=t&omega=132.2&transient=1000&periods=16",
    );
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&body));
    let t = json(&body);
    // The README's tour: at 132.2 rad/s the rotor settles on a period-2 response.
    assert_eq!(t["class"], "period-2");
    let m = t["floquet"]["multipliers"].as_array().unwrap();
    assert_eq!(m.len(), STATE_DIM);
    assert_eq!(t["floquet"]["stable"], true);
}

#[test]
fn loopback_answers_only_its_own_address() {
    let r = start(false);
    let a = r.ex.addr();
    assert!(a.ip().is_loopback());
    assert_eq!(get_as(a, "attacker.example", "", "/api/info").0, 403);
}

#[test]
fn with_a_host_every_request_needs_the_token() {
    let r = start(true);
    let a = r.ex.addr();
    let token = r.ex.token().unwrap().to_string();
    assert_eq!(token.len(), 32);
    assert!(r.ex.url().ends_with(&format!("?token={token}")));
    assert_eq!(get(a, "/api/info").0, 401);
    assert_eq!(get(a, "/api/info?token=0123").0, 401);
    assert_eq!(get(a, &format!("/api/info?token={token}")).0, 200);
    let header = format!("X-Jeffcott-Token: {token}\r\n");
    assert_eq!(get_as(a, "127.0.0.1", &header, "/api/info").0, 200);
}

#[test]
fn saves_go_into_out_under_names_the_server_chooses() {
    let r = start(false);
    let a = r.ex.addr();
    let post = |q: &str, body: &[u8]| {
        let mut raw = format!(
            "POST /api/save?{q} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
            a.port(),
            body.len()
        )
        .into_bytes();
        raw.extend_from_slice(body);
        send(a, &raw)
    };
    assert_eq!(
        post("tab=t&view=basin&kind=npy&note=jeffcott%20basin", b"abc").0,
        200
    );
    assert_eq!(post("tab=t&view=basin&kind=npy", b"def").0, 200);
    let dir = r.out.path().join("saved");
    assert_eq!(std::fs::read(dir.join("basin-1.npy")).unwrap(), b"abc");
    assert_eq!(std::fs::read(dir.join("basin-2.npy")).unwrap(), b"def");
    assert_eq!(
        std::fs::read_to_string(dir.join("basin-1.npy.txt")).unwrap(),
        "jeffcott basin\n"
    );
    assert_eq!(post("tab=t&view=../../x&kind=npy", b"x").0, 400);
    assert_eq!(post("tab=t&view=basin&kind=sh", b"x").0, 400);
}

#[test]
fn the_page_shows_the_parameter_table_of_the_docs() {
    let doc = include_str!("../docs/parameters.md");
    for i in Params::info() {
        let row = doc
            .lines()
            .find(|l| l.starts_with(&format!("| `{}` |", i.name)))
            .unwrap_or_else(|| panic!("{} has no row in docs/parameters.md", i.name));
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        assert_eq!(cells[2], i.symbol, "{}", i.name);
        assert_eq!(cells[3], i.unit, "{}", i.name);
        assert_eq!(cells[4].parse::<f64>().unwrap(), i.default, "{}", i.name);
        let allowed = i
            .allowed
            .trim_start_matches("must be ")
            .replace(" and ", ", ");
        assert_eq!(cells[5], allowed, "{}", i.name);
    }
}

#[test]
fn a_basin_view_is_the_basin_its_command_computes() {
    use jeffcott_analysis::basin::{Axis, BasinSpec, base_state, basin};
    use jeffcott_analysis::catalogue::CatalogueConfig;
    use jeffcott_analysis::settings::LaneSettings;
    let r = start(false);
    let (status, body) = get(
        r.ex.addr(),
        "/api/basin?tab=t&omega=133&x=x_r&xlo=-0.006&xhi=0.006&y=vx_r&ylo=-1&yhi=1&n=6&transient=80&periods=8",
    );
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&body));
    let view = json(&body);
    let p = Params::default();
    let x = Axis {
        coord: 0,
        lo: -0.006,
        hi: 0.006,
        n: 6,
    };
    let y = Axis {
        coord: 1,
        lo: -1.0,
        hi: 1.0,
        n: 6,
    };
    let spec = BasinSpec {
        base: base_state(&p, &x, &y, &[], StepperConfig::DEFAULT.divergence_bound).unwrap(),
        lane: LaneSettings {
            params: p,
            stepper: StepperConfig::DEFAULT,
            precision: Precision::F64,
            backend: Backend::Cpu,
            catalogue: CatalogueConfig::for_precision(Precision::F64),
            lyapunov: false,
        },
        omega: 133.0,
        x,
        y,
        transient: 80,
        periods: 8,
        lanes_per_unit: None,
    };
    let want = basin(&spec, Control::none()).unwrap();
    let got: Vec<i32> = view["labels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_i64().unwrap() as i32)
        .collect();
    assert_eq!(got, want.labels);
    assert_eq!(
        view["attractors"].as_array().unwrap().len(),
        want.catalogue.attractors.len()
    );
}
