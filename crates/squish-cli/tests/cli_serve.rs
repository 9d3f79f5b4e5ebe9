//! `squish serve` over HTTP: the page and the API on a copy of the press example, requests that
//! must be refused (malformed JSON, wrong types, unknown keys, huge bodies, names that leave the
//! scene's folder) without the server failing, fast edits, the exported scene, and a clean stop
//! on Ctrl-C. (The page itself is tested in Chromium by web/test.sh.)

#![allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

struct Server {
    child: Child,
    address: String,
    _folder: tempfile::TempDir,
}

impl Server {
    /// `squish serve` on a copy of examples/press, on a free port.
    fn start() -> (Self, std::path::PathBuf) {
        let folder = tempfile::tempdir().unwrap();
        let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/press");
        for file in ["press.toml", "ball.obj", "ground.obj"] {
            std::fs::copy(examples.join(file), folder.path().join(file)).unwrap();
        }
        Self::start_in(folder, "press.toml")
    }

    /// `squish serve SCENE` in `folder`, on a free port.
    fn start_in(folder: tempfile::TempDir, scene: &str) -> (Self, std::path::PathBuf) {
        let mut child = Command::new(env!("CARGO_BIN_EXE_squish"))
            .args(["serve", scene, "--port", "0"])
            .current_dir(folder.path())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
        let address = line.split("http://").nth(1).unwrap().split('/').next().unwrap().to_string();
        let path = folder.path().to_path_buf();
        (Self { child, address, _folder: folder }, path)
    }

    /// One HTTP/1.1 request; the status and body.
    fn request(&self, method: &str, path: &str, body: &[u8]) -> (u16, String) {
        let mut stream = TcpStream::connect(&self.address).unwrap();
        stream.set_read_timeout(Some(Duration::from_secs(120))).unwrap();
        let head = format!(
            "{method} {path} HTTP/1.1\r\nHost: {}\r\nContent-Length: {}\r\nContent-Type: application/json\r\nConnection: close\r\n\r\n",
            self.address,
            body.len()
        );
        stream.write_all(head.as_bytes()).unwrap();
        // A refused body may close the connection before it is all sent.
        let _ = stream.write_all(body);
        let mut response = Vec::new();
        let _ = stream.read_to_end(&mut response);
        let text = String::from_utf8_lossy(&response).into_owned();
        let status = text.split(' ').nth(1).and_then(|s| s.parse().ok()).unwrap_or(0);
        let body = text.split_once("\r\n\r\n").map(|(_, b)| b.to_string()).unwrap_or_default();
        (status, body)
    }

    fn message(&self, json: &str) -> (u16, serde_json::Value) {
        let (status, body) = self.request("POST", "/api/message", json.as_bytes());
        (status, serde_json::from_str(&dechunk(&body)).unwrap_or(serde_json::Value::Null))
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The body of a chunked response (axum streams some bodies).
fn dechunk(body: &str) -> String {
    if body.starts_with('{') || body.starts_with('<') {
        return body.to_string();
    }
    let mut out = String::new();
    let mut rest = body;
    while let Some((size, tail)) = rest.split_once("\r\n") {
        let Ok(n) = usize::from_str_radix(size.trim(), 16) else { break };
        if n == 0 || tail.len() < n {
            break;
        }
        out.push_str(&tail[..n]);
        rest = tail[n..].trim_start_matches("\r\n");
    }
    out
}

fn interrupt(child: &Child) {
    let status = Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
    assert!(status.success());
}

#[test]
fn serves_the_page_and_refuses_bad_requests_without_failing() {
    let (server, folder) = Server::start();
    let (status, page) = server.request("GET", "/", b"");
    assert_eq!(status, 200);
    assert!(page.contains("squish serve"));
    assert_eq!(server.request("GET", "/assets/../Cargo.toml", b"").0, 404);
    assert_eq!(server.request("GET", "/assets/%2e%2e%2fpress.toml", b"").0, 404);

    for (bad, says) in [
        ("not json", "malformed message"),
        ("{\"type\": \"frame\", \"frame\": \"ten\"}", "malformed message"),
        ("{\"type\": \"set\", \"target\": {\"object\": 0}, \"key\": \"stiffness\", \"value\": [1, 2]}", "stiffness"),
        ("{\"type\": \"set\", \"target\": {\"object\": 9}, \"key\": \"stiffness\", \"value\": 2}", "no object 9"),
        ("{\"type\": \"set\", \"target\": {\"object\": 0}, \"key\": \"stifness\", \"value\": 2}", "stiffness"),
        ("{\"type\": \"set\", \"target\": {\"object\": 0}, \"key\": \"stiffness\", \"value\": -1}", "stiffness"),
        ("{\"type\": \"set\", \"target\": {\"pair\": 0}, \"key\": \"contact_tau\", \"value\": true}", "contact_tau"),
        ("{\"type\": \"frame\", \"frame\": 4000}", "outside the scene's frames"),
        (
            "{\"type\": \"paint\", \"object\": 0, \"stroke\": {\"center\": [0, 0, 0], \"radius\": -1, \"operation\": \"add\", \"strength\": 1}}",
            "radius",
        ),
        ("{\"type\": \"export\", \"name\": \"../outside\"}", "export name"),
        ("{\"type\": \"export\", \"name\": \"/etc/passwd\"}", "export name"),
        ("{\"type\": \"export\", \"name\": \"a/b\"}", "export name"),
    ] {
        let (status, reply) = server.message(bad);
        assert_eq!(status, 400, "{bad}: {reply}");
        assert_eq!(reply["type"], "error", "{bad}");
        assert!(reply["message"].as_str().unwrap().contains(says), "{bad}: {reply}");
    }
    // A body over the bound is refused before it is read.
    let huge = format!("{{\"type\": \"refresh\", \"pad\": \"{}\"}}", "x".repeat(4 << 20));
    assert_eq!(server.request("POST", "/api/message", huge.as_bytes()).0, 413);
    // Nothing was written outside the folder, and the server still answers.
    assert!(!folder.parent().unwrap().join("outside.toml").exists());
    let (status, reply) = server.message("{\"type\": \"frame\", \"frame\": 24}");
    assert_eq!(status, 200, "{reply}");
    assert_eq!(reply["frame"]["frame"], 24);
}

#[test]
fn a_downstream_edit_is_fast_and_the_export_renders_the_same_with_squish_run() {
    let (server, folder) = Server::start();
    let (_, full) = server.message("{\"type\": \"frame\", \"frame\": 24}");
    assert_eq!(full["frame"]["edit"], false, "{} {}", full["frame"]["version"], full["frame"]["frame"]);
    let (_, edited) =
        server.message("{\"type\": \"set\", \"target\": {\"object\": 0}, \"key\": \"profile_v2\", \"value\": 0.5}");
    assert_eq!(edited["frame"]["edit"], true, "a profile abscissa is downstream of the contact: a fast edit");
    assert_ne!(edited["frame"]["objects"][0]["output"], full["frame"]["objects"][0]["output"]);
    let (_, keyed) = server.message(
        "{\"type\": \"set\", \"target\": {\"object\": 1}, \"key\": \"stiffness\", \"value\": 2, \"keyframe\": true}",
    );
    assert_eq!(keyed["frame"]["values"]["objects"][1]["stiffness"]["keys"], serde_json::json!([24.0]));
    let (_, unkeyed) = server.message("{\"type\": \"unkey\", \"target\": {\"object\": 1}, \"key\": \"stiffness\"}");
    assert_eq!(unkeyed["frame"]["values"]["objects"][1]["stiffness"]["edited"], false, "the last key removed");
    let (status, _) = server.message("{\"type\": \"unkey\", \"target\": {\"object\": 1}, \"key\": \"stiffness\"}");
    assert_eq!(status, 400, "no key left to remove");
    server.message(
        "{\"type\": \"set\", \"target\": {\"object\": 1}, \"key\": \"stiffness\", \"value\": 2, \"keyframe\": true}",
    );
    let (status, exported) = server.message("{\"type\": \"export\", \"name\": \"edited\"}");
    assert_eq!(status, 200, "{exported}");
    let (_, shown) = server.message("{\"type\": \"refresh\"}");

    let out = run_exported(&folder, 24);
    // The exported meshes of the page's frame and squish run's, both written by the same OBJ
    // writer (shortest round-trip decimals): the same text is the same bits.
    for (i, name) in ["ball", "ground"].iter().enumerate() {
        let run = obj_vertices(&out.join(name).join("0024.obj"));
        let page = obj_vertices(&folder.join("edited-frame-24").join(format!("{name}.obj")));
        assert_eq!(run.len(), page.len(), "{name}: vertex count");
        let first_difference = run.iter().zip(&page).position(|(a, b)| a != b);
        assert_eq!(first_difference.map(|k| (&run[k], &page[k])), None, "{name}: squish run renders the page's frame");
        // The page's positions (JSON, read here by a parser that may round the last bit).
        let shown: Vec<f64> =
            shown["frame"]["objects"][i]["output"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
        let written: Vec<f64> =
            run.iter().flat_map(|l| l[2..].split_whitespace().map(|x| x.parse::<f64>().unwrap())).collect();
        let off = written.iter().zip(&shown).map(|(a, b)| (a - b).abs() / a.abs().max(1e-300)).fold(0.0, f64::max);
        assert!(off < 1e-15, "{name}: the page's positions are the exported ones ({off})");
    }
}

#[test]
fn ctrl_c_stops_the_server_cleanly() {
    let (mut server, _) = Server::start();
    assert_eq!(server.request("GET", "/api/scene", b"").0, 200);
    interrupt(&server.child);
    let start = Instant::now();
    loop {
        if let Some(status) = server.child.try_wait().unwrap() {
            assert!(status.success(), "exit status {status}");
            break;
        }
        assert!(start.elapsed() < Duration::from_secs(20), "the server did not stop on Ctrl-C");
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn listening_beyond_this_machine_warns() {
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/press");
    let mut child = Command::new(env!("CARGO_BIN_EXE_squish"))
        .args(["serve", "press.toml", "--port", "0", "--listen", "0.0.0.0"])
        .current_dir(&examples)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut warning = String::new();
    BufReader::new(child.stderr.take().unwrap()).read_line(&mut warning).unwrap();
    let _ = child.kill();
    let _ = child.wait();
    assert!(warning.starts_with("warning: listening on 0.0.0.0:"), "{warning}");
    assert!(warning.contains("127.0.0.1"), "the warning says what to use instead: {warning}");
}

#[test]
fn a_radial_stroke_paints_only_the_selected_region_and_a_malformed_kind_is_refused() {
    let (server, _) = Server::start();
    let (_, scene) = server.request("GET", "/api/scene", b"");
    let scene: serde_json::Value = serde_json::from_str(&dechunk(&scene)).unwrap();
    let (_, shown) = server.message("{\"type\": \"frame\", \"frame\": 24}");
    let ball = &shown["frame"]["objects"][0];
    let numbers =
        |v: &serde_json::Value| -> Vec<f64> { v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect() };
    let flags = |v: &serde_json::Value| -> Vec<bool> { numbers(v).iter().map(|&x| x != 0.0).collect() };
    let flat = numbers(&ball["input"]);
    let triangles: Vec<u32> = numbers(&scene["objects"][0]["triangles"]).iter().map(|&x| x as u32).collect();
    let mesh = squish::TriMesh {
        positions: flat.chunks_exact(3).map(|p| glam::DVec3::new(p[0], p[1], p[2])).collect(),
        triangles: triangles.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
    };
    let u: Vec<f64> =
        numbers(&ball["overlays"]["u"]).iter().map(|&x| if x < 0.0 { f64::INFINITY } else { x }).collect();
    let contact = flags(&ball["overlays"]["contact"]);
    let deformable = flags(&ball["overlays"]["deformable"]);
    // The brush centre: the vertex of 𝒟 nearest to u = ½.
    let centre = (0..u.len())
        .filter(|&v| deformable[v])
        .min_by(|&a, &b| (u[a] - 0.5).abs().total_cmp(&(u[b] - 0.5).abs()))
        .unwrap();
    let at = mesh.positions[centre];
    let radius = 0.3;
    // The selection the core makes on the fields the page was sent.
    let topology = squish::mesh::Topology::new(&mesh);
    let fields = squish::deform::BrushFields { u: &u, contact: &contact, deformable: &deformable };
    let selection = squish::deform::radial_brush(&mesh, &topology, &fields, at, radius).unwrap();

    let stroke = |kind: &str, at: glam::DVec3| {
        format!(
            "{{\"type\": \"paint\", \"object\": 0, \"stroke\": {{\"kind\": \"{kind}\", \"center\": [{}, {}, {}], \"radius\": {radius}, \"operation\": \"add\", \"strength\": 1}}}}",
            at.x, at.y, at.z
        )
    };
    let (status, painted) = server.message(&stroke("radial", at));
    assert_eq!(status, 200, "{painted}");
    let eta = numbers(&painted["frame"]["objects"][0]["painted"]);
    let mut changed = 0;
    for (v, &eta) in eta.iter().enumerate() {
        if eta != 1.0 {
            assert!(selection.selected[v], "η changed at vertex {v}, outside the selected region");
            changed += 1;
        }
        let w = selection.weights[v];
        assert!((eta - 1.0 - w).abs() < 1e-9, "vertex {v}: η = {eta}, w = {w}");
    }
    assert!(changed > 20, "{changed} vertices painted");
    assert_eq!(painted["frame"]["edit"], true, "the bulge map is downstream: a fast edit");

    for (bad, says) in [
        (stroke("cone", at), "unknown variant"),
        (stroke("radial", mesh.positions[contact.iter().position(|&c| c).unwrap()]), "outside the deformable region"),
    ] {
        let (status, reply) = server.message(&bad);
        assert_eq!(status, 400, "{bad}: {reply}");
        assert!(reply["message"].as_str().unwrap().contains(says), "{bad}: {reply}");
    }
}

/// The output positions of a frame the page was sent, per object.
fn outputs(frame: &serde_json::Value) -> Vec<Vec<f64>> {
    frame["frame"]["objects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| o["output"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect())
        .collect()
}

fn largest_difference(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

/// `squish run edited.toml --frames N -o run` in `folder` (a page's export): the output folder.
fn run_exported(folder: &Path, frame: i64) -> std::path::PathBuf {
    let out = folder.join("run");
    let run = Command::new(env!("CARGO_BIN_EXE_squish"))
        .args(["run", "edited.toml", "--frames", &frame.to_string(), "-o"])
        .arg(&out)
        .current_dir(folder)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    out
}

/// The `v` lines of an OBJ file.
fn obj_vertices(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines().filter(|l| l.starts_with("v ")).map(str::to_string).collect()
}

/// `squish run` of the scene the page exports renders the page's frame, bit for bit.
fn assert_export_renders(server: &Server, folder: &Path, frame: i64, names: &[&str]) {
    let (status, exported) = server.message("{\"type\": \"export\", \"name\": \"edited\"}");
    assert_eq!(status, 200, "{exported}");
    let out = run_exported(folder, frame);
    for name in names {
        let run = obj_vertices(&out.join(name).join(format!("{frame:04}.obj")));
        let page = obj_vertices(&folder.join(format!("edited-frame-{frame}")).join(format!("{name}.obj")));
        assert!(run == page, "{name}: squish run does not render the page's frame");
    }
}

/// CesiumMan (`self_contact = "auto"`, ../shared/data): the page is told the world is y-up, gets
/// the character's texture and the mesh split along its UV seams, lists its articulations and
/// parts and marks the object's stiffness as having no effect (the object is in no pair); the
/// self-contact's times are reported; an articulation's stiffness and the object's `untangle`
/// change the result, and the exported scene renders it with `squish run`.
#[test]
fn cesium_man_is_upright_textured_and_its_self_contact_settings_take_effect() {
    let glb = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/rigged/CesiumMan.glb");
    if !glb.is_file() {
        println!("skipped: {} is absent", glb.display());
        return;
    }
    let folder = tempfile::tempdir().unwrap();
    let scene = format!(
        "frames = {{ start = 1, end = 48, fps = 24 }}\n[[objects]]\nname = \"cesium_man\"\nmesh = {{ file = {:?}, repeat = true }}\nself_contact = \"auto\"\n",
        glb.canonicalize().unwrap().display().to_string()
    );
    std::fs::write(folder.path().join("cesium.toml"), scene).unwrap();
    let (server, folder) = Server::start_in(folder, "cesium.toml");
    let (status, body) = server.request("GET", "/api/scene", b"");
    assert_eq!(status, 200);
    let view: serde_json::Value = serde_json::from_str(&dechunk(&body)).unwrap();
    let man = &view["objects"][0];
    assert_eq!(view["up"], "y", "glTF is y-up");
    let articulations: Vec<&str> =
        man["articulations"].as_array().unwrap().iter().map(|a| a["name"].as_str().unwrap()).collect();
    let parts = man["parts"].as_array().unwrap();
    println!("CesiumMan: {} articulations ({}), {} parts", articulations.len(), articulations.join(", "), parts.len());
    assert!(
        articulations.len() >= 8 && man["articulations"].as_array().unwrap().iter().all(|a| a["automatic"] == true)
    );
    assert!(parts.len() >= 8);
    assert!(man["inert"]["stiffness"].as_str().unwrap().contains("articulation's stiffness"));
    let display = &man["display"];
    let drawn = display["vertex"].as_array().unwrap().len();
    assert!(drawn > 2338 && display["uv"].as_array().unwrap().len() == 2 * drawn, "{drawn} drawn vertices");
    assert_eq!(man["texture"], "api/texture/0");
    let mut stream = TcpStream::connect(&server.address).unwrap();
    write!(stream, "GET /api/texture/0 HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n").unwrap();
    let mut response = Vec::new();
    stream.read_to_end(&mut response).unwrap();
    let split = response.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
    let head = String::from_utf8_lossy(&response[..split]).to_lowercase();
    // The mesh node's texture, as the file holds it (the node is the file's only one with a mesh).
    let image = (0..64).find_map(|node| squish_io::base_color_image(&glb, node).ok().flatten()).unwrap();
    assert!(head.starts_with("http/1.1 200") && head.contains(&format!("content-type: {}", image.mime)), "{head}");
    assert!(
        response[split + 4..].windows(image.bytes.len().min(64)).any(|w| w == &image.bytes[..w.len()]),
        "the file's image"
    );
    assert_eq!(server.request("GET", "/api/texture/5", b"").0, 404);

    let (_, base) = server.message("{\"type\": \"frame\", \"frame\": 9}");
    let stages = base["frame"]["stages"].as_object().unwrap();
    let parts_ms = stages["self-contact: parts"].as_f64().unwrap();
    println!("frame 9 stages (ms): {stages:?}");
    assert!(parts_ms > 0.0 && stages["self-contact: articulations"].as_f64().unwrap() > 0.0);
    let knee = articulations.iter().position(|n| n.contains("leg_joint_L_1") && n.contains("leg_joint_L_2")).unwrap();
    assert!(base["frame"]["articulations"][knee]["faces_before"].as_u64().is_some());

    // The object's stiffness changes nothing (and the page says why) …
    let (_, stiffer_object) =
        server.message("{\"type\": \"set\", \"target\": {\"object\": 0}, \"key\": \"stiffness\", \"value\": 4}");
    assert_eq!(outputs(&stiffer_object), outputs(&base));
    // … an articulation's does, and so does the object's untangling.
    let message = format!(
        "{{\"type\": \"set\", \"target\": {{\"articulation\": [0, {knee}]}}, \"key\": \"stiffness\", \"value\": [1, 4]}}"
    );
    let (status, stiffer_knee) = server.message(&message);
    assert_eq!(status, 200, "{stiffer_knee}");
    let moved = largest_difference(&outputs(&stiffer_knee)[0], &outputs(&base)[0]);
    assert_eq!(stiffer_knee["frame"]["values"]["articulations"][0][knee]["stiffness"]["edited"], true);
    let (_, raw) =
        server.message("{\"type\": \"set\", \"target\": {\"object\": 0}, \"key\": \"untangle\", \"value\": false}");
    let untangled = largest_difference(&outputs(&raw)[0], &outputs(&stiffer_knee)[0]);
    println!("left knee stiffness [1, 4]: vertices move up to {moved:.2e}; untangle off: {untangled:.2e}");
    assert!(moved > 1e-4 && untangled > 1e-4);
    let (status, bad) = server
        .message("{\"type\": \"set\", \"target\": {\"articulation\": [0, 99]}, \"key\": \"stiffness\", \"value\": 2}");
    assert!(status == 400 && bad["message"].as_str().unwrap().contains("no articulation 99"), "{bad}");
    assert_export_renders(&server, &folder, 9, &["cesium_man"]);
}

/// A pair switched to the shared parametrization on the page reads its objects' UVs (OBJ `vt`):
/// the result changes, and the exported scene renders it; an object without UVs is an error
/// naming its file.
#[test]
fn the_shared_parametrization_is_one_setting_away() {
    let folder = tempfile::tempdir().unwrap();
    let obj = |mesh: &squish::TriMesh, uvs: bool| -> String {
        let mut text = String::new();
        for p in &mesh.positions {
            text += &format!("v {:?} {:?} {:?}\n", p.x, p.y, p.z);
            if uvs {
                // The projection along (0.5, 0, 1): matched along it, not along the normals.
                text += &format!("vt {:?} {:?}\n", p.x - 0.5 * p.z, p.y);
            }
        }
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|v| v + 1);
            text += &if uvs { format!("f {a}/{a} {b}/{b} {c}/{c}\n") } else { format!("f {a} {b} {c}\n") };
        }
        text
    };
    let mut ball = squish::mesh::shapes::icosphere(0.5, 3);
    ball.map_positions(|p| p + glam::DVec3::new(0.1, 0.0, 0.4));
    let ground = squish::mesh::shapes::grid(2.0, 2.0, 30, 30);
    std::fs::write(folder.path().join("ball.obj"), obj(&ball, true)).unwrap();
    std::fs::write(folder.path().join("ground.obj"), obj(&ground, true)).unwrap();
    std::fs::write(folder.path().join("bare.obj"), obj(&ground, false)).unwrap();
    let scene = |ground: &str| {
        format!(
            "frames = {{ start = 1, end = 1 }}\n[[objects]]\nname = \"ball\"\nmesh = \"ball.obj\"\nrigid = true\n\
             [[objects]]\nname = \"ground\"\nmesh = \"{ground}\"\n[[pairs]]\nobjects = [\"ball\", \"ground\"]\n"
        )
    };
    std::fs::write(folder.path().join("uv.toml"), scene("ground.obj")).unwrap();
    std::fs::write(folder.path().join("bare.toml"), scene("bare.obj")).unwrap();
    let bare_folder = tempfile::tempdir().unwrap();
    for file in ["ball.obj", "bare.obj", "bare.toml"] {
        std::fs::copy(folder.path().join(file), bare_folder.path().join(file)).unwrap();
    }
    let (server, folder) = Server::start_in(folder, "uv.toml");
    let (_, unique) = server.message("{\"type\": \"refresh\"}");
    let set =
        "{\"type\": \"set\", \"target\": {\"pair\": 0}, \"key\": \"mapping\", \"value\": \"shared_parametrization\"}";
    let (status, shared) = server.message(set);
    assert_eq!(status, 200, "{shared}");
    assert_eq!(shared["frame"]["pairs"][0]["in_contact"], true, "{}", shared["frame"]["pairs"]);
    let changed = largest_difference(&outputs(&shared)[1], &outputs(&unique)[1]);
    println!("the ground with the shared parametrization: {changed:.2e} from the unique direction's");
    assert!(changed > 1e-6);
    assert_export_renders(&server, &folder, 1, &["ball", "ground"]);

    let (bare, _) = Server::start_in(bare_folder, "bare.toml");
    let (status, error) = bare.message(set);
    let message = error["message"].as_str().unwrap_or_default();
    assert!(status == 422 && message.contains("bare.obj") && message.contains("'vt'"), "{status} {error}");
}
