//! `squish serve [SCENE.toml | A B] [--port N] [--listen ADDR] [--open]`: a live browser preview
//! for art direction. An HTTP and WebSocket server (axum on tokio) serves the page (embedded in
//! the binary, [`assets`]) and computes the frames the page asks for with the core's fast edits
//! (thesis §5.4–5.5: a change of the profile, bulge, wrinkles, bulge map or anisotropy at the
//! same frame reuses the contact definition, parametrization and factorizations).
//!
//! **Contract.**
//! - Bound to 127.0.0.1 unless `--listen` says otherwise (then a warning: the page can write
//!   files in the scene's folder and has no login).
//! - Messages (`{"type": …}`, [`messages`]) arrive on the WebSocket `/api/ws` or as the body of
//!   `POST /api/message`; each changes the session's edits at once and wakes the one compute
//!   worker, which always takes the latest edits: a drag never queues stale work (intermediate
//!   values are dropped, never computed). Every client is sent the latest frame.
//! - Reads nothing on request but the embedded page; writes only directly inside the scene's
//!   folder ([`export`]). Bodies and WebSocket messages are bounded ([`MAX_MESSAGE_BYTES`]);
//!   malformed messages get an error naming what is wrong, which the page shows; no request
//!   panics the server (a panic in a computation is caught and reported as an error).
//! - Ctrl-C stops accepting, closes the WebSockets and returns once connections are done.

mod assets;
mod export;
mod messages;
mod session;
mod view;

use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};

use axum::Router;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{DefaultBodyLimit, State};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use clap::Args;
use squish::Deformer;
use squish_io::Scene;
use tokio::sync::watch;

use crate::error::CliError;
use messages::{Reply, Request};
use session::{BrushFrame, Computed, Session};
use view::{FrameView, SceneView};

/// Largest request body or WebSocket message (a message is an edit, never a mesh).
pub const MAX_MESSAGE_BYTES: usize = 1 << 20;

#[derive(Args, Debug)]
pub struct ServeArgs {
    /// A scene file (TOML), or two meshes (OBJ, PLY, glTF) to put in contact.
    #[arg(num_args = 1..=2, required = true, value_name = "SCENE.toml | A B")]
    pub inputs: Vec<PathBuf>,
    /// Port to listen on (0: any free port, printed).
    #[arg(long, default_value_t = 7878)]
    pub port: u16,
    /// Address to listen on. Default 127.0.0.1 (this machine only).
    #[arg(long, value_name = "ADDR")]
    pub listen: Option<IpAddr>,
    /// Open the page in the default browser.
    #[arg(long)]
    pub open: bool,
}

/// The server's shared state.
struct App {
    session: Mutex<Session>,
    engine: Mutex<Engine>,
    /// Bumped by every change of the edits; the compute worker follows it.
    edits_version: watch::Sender<u64>,
    /// The latest computed frame (or error) as sent to the page.
    latest: watch::Sender<Option<Arc<Outcome>>>,
    /// Set on Ctrl-C: WebSockets close.
    shutdown: watch::Sender<bool>,
    /// The fields of the frame last computed, which the radial brush follows (kept apart from
    /// the engine, whose lock a computation holds).
    brush_frame: Mutex<Option<Arc<BrushFrame>>>,
}

/// The deformer and what it keeps between frames.
struct Engine {
    deformer: Deformer,
    last: Option<Computed>,
}

/// A computation's outcome for a version of the edits: the frame's JSON, or an error.
struct Outcome {
    version: u64,
    json: String,
    ok: bool,
}

pub fn run(args: &ServeArgs) -> Result<(), CliError> {
    let (scene, folder) = load_inputs(&args.inputs)?;
    let session = Session::new(scene, folder);
    // The first frame is computed before listening, so that a scene that cannot run says so here.
    session.frame(&session.edits).map_err(CliError::input)?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .map_err(|e| CliError::failure(format!("cannot start the server's runtime: {e}")))?;
    let address = SocketAddr::new(args.listen.unwrap_or(IpAddr::V4(Ipv4Addr::LOCALHOST)), args.port);
    runtime.block_on(serve(session, address, args.open))
}

/// The scene of the inputs and its folder: a scene file's, or for two meshes a one-frame scene
/// of them (in the first mesh's folder).
fn load_inputs(inputs: &[PathBuf]) -> Result<(Scene, PathBuf), CliError> {
    let absolute = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let folder_of = |p: &Path| absolute(p).parent().map(Path::to_path_buf).unwrap_or_else(|| PathBuf::from("."));
    match inputs {
        [scene] => {
            let scene = Scene::load(scene).map_err(|e| CliError::input(e.to_string()))?;
            let folder = folder_of(scene.path());
            Ok((scene, folder))
        }
        [a, b] => {
            let name = |p: &Path, other: &str| {
                let stem = p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "mesh".into());
                if stem == other { format!("{stem}-2") } else { stem }
            };
            let (name_a, path_a) = (name(a, ""), absolute(a));
            let (name_b, path_b) = (name(b, &name_a), absolute(b));
            let quoted = |s: &str| toml::Value::String(s.to_string()).to_string();
            let text = format!(
                "frames = {{ start = 1, end = 1 }}\n\n[[objects]]\nname = {}\nmesh = {}\n\n[[objects]]\nname = {}\nmesh = {}\n\n\
                 [[pairs]]\nobjects = [{}, {}]\n",
                quoted(&name_a),
                quoted(&path_a.to_string_lossy()),
                quoted(&name_b),
                quoted(&path_b.to_string_lossy()),
                quoted(&name_a),
                quoted(&name_b)
            );
            let folder = folder_of(a);
            let scene = Scene::from_toml(&text, &folder.join(format!("{name_a}-{name_b}.toml")))
                .map_err(|e| CliError::input(e.to_string()))?;
            Ok((scene, folder))
        }
        _ => Err(CliError::input("give a scene file, or two meshes")),
    }
}

async fn serve(session: Session, address: SocketAddr, open: bool) -> Result<(), CliError> {
    let (edits_version, versions) = watch::channel(0u64);
    let app = Arc::new(App {
        session: Mutex::new(session),
        engine: Mutex::new(Engine { deformer: Deformer::new().keep_for_edits(), last: None }),
        edits_version,
        latest: watch::channel(None).0,
        shutdown: watch::channel(false).0,
        brush_frame: Mutex::new(None),
    });
    let listener = tokio::net::TcpListener::bind(address)
        .await
        .map_err(|e| CliError::failure(format!("cannot listen on {address}: {e}; choose another --port")))?;
    let bound = listener.local_addr().map_err(|e| CliError::failure(e.to_string()))?;
    if !bound.ip().is_loopback() {
        eprintln!(
            "warning: listening on {bound}, reachable from other machines: anyone who reaches it can change \
             parameters and write files in the scene's folder; use the default 127.0.0.1 unless on a trusted network"
        );
    }
    let url = format!(
        "http://{}/",
        if bound.ip().is_unspecified() { SocketAddr::new(Ipv4Addr::LOCALHOST.into(), bound.port()) } else { bound }
    );
    println!("squish serve: {url} (Ctrl-C to stop)");
    if open {
        open_browser(&url);
    }
    tokio::spawn(compute_worker(app.clone(), versions));
    let router = router(app.clone());
    let shutdown = app.shutdown.clone();
    axum::serve(listener, router)
        .with_graceful_shutdown(async move {
            let _ = tokio::signal::ctrl_c().await;
            eprintln!("squish serve: stopping");
            let _ = shutdown.send(true);
        })
        .await
        .map_err(|e| CliError::failure(format!("server stopped: {e}")))?;
    Ok(())
}

fn open_browser(url: &str) {
    let opener = if cfg!(target_os = "macos") { "open" } else { "xdg-open" };
    if let Err(e) = std::process::Command::new(opener).arg(url).spawn() {
        eprintln!("note: cannot open a browser ({opener}: {e}); open {url} yourself");
    }
}

fn router(app: Arc<App>) -> Router {
    Router::new()
        .route("/", get(|| async { assets::response("index.html") }))
        .route(
            "/assets/{file}",
            get(|axum::extract::Path(file): axum::extract::Path<String>| async move {
                assets::response(&format!("assets/{file}"))
            }),
        )
        .route("/api/scene", get(scene_handler))
        .route("/api/texture/{object}", get(texture_handler))
        .route("/api/frame", get(frame_handler))
        .route("/api/message", post(message_handler))
        .route("/api/ws", get(ws_handler))
        .layer(DefaultBodyLimit::max(MAX_MESSAGE_BYTES))
        .with_state(app)
}

/// The lock, even if a computation panicked while holding it (its data stays consistent: every
/// change is made whole or not at all).
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

fn json_response(status: StatusCode, body: String) -> Response {
    (status, [(header::CONTENT_TYPE, "application/json")], body).into_response()
}

fn error_json(message: &str) -> String {
    serde_json::json!({ "type": "error", "message": message }).to_string()
}

async fn scene_handler(State(app): State<Arc<App>>) -> Response {
    let session = lock(&app.session);
    match SceneView::of(&session).and_then(|v| serde_json::to_string(&v).map_err(|e| e.to_string())) {
        Ok(json) => json_response(StatusCode::OK, json),
        Err(message) => json_response(StatusCode::INTERNAL_SERVER_ERROR, error_json(&message)),
    }
}

/// An object's base-colour texture, as the glTF file holds it (404 without one).
async fn texture_handler(
    State(app): State<Arc<App>>,
    axum::extract::Path(object): axum::extract::Path<usize>,
) -> Response {
    let session = lock(&app.session);
    match session.textures.get(object).and_then(Option::as_ref) {
        Some(image) => ([(header::CONTENT_TYPE, image.mime.clone())], image.bytes.clone()).into_response(),
        None => (StatusCode::NOT_FOUND, "no texture").into_response(),
    }
}

/// The latest frame computed for the current edits (waits for it).
async fn frame_handler(State(app): State<Arc<App>>) -> Response {
    let version = *app.edits_version.borrow();
    let outcome = outcome_for(&app, version).await;
    json_response(if outcome.ok { StatusCode::OK } else { StatusCode::UNPROCESSABLE_ENTITY }, outcome.json.clone())
}

/// A message as a request body: applied, then answered with the frame it leads to (or with what
/// it wrote, for an export).
async fn message_handler(State(app): State<Arc<App>>, body: axum::body::Bytes) -> Response {
    match handle(&app, &body).await {
        Ok(Reply::Wait(version)) => {
            let outcome = outcome_for(&app, version).await;
            json_response(
                if outcome.ok { StatusCode::OK } else { StatusCode::UNPROCESSABLE_ENTITY },
                outcome.json.clone(),
            )
        }
        Ok(Reply::Now(json)) => json_response(StatusCode::OK, json),
        Err(message) => json_response(StatusCode::BAD_REQUEST, error_json(&message)),
    }
}

/// Waits for the outcome of edits version `version` or a later one.
async fn outcome_for(app: &App, version: u64) -> Arc<Outcome> {
    let mut latest = app.latest.subscribe();
    loop {
        if let Some(outcome) = latest.borrow_and_update().clone().filter(|o| o.version >= version) {
            return outcome;
        }
        if latest.changed().await.is_err() {
            return Arc::new(Outcome { version, json: error_json("the server is stopping"), ok: false });
        }
    }
}

/// Applies one message (JSON text) to the session.
async fn handle(app: &Arc<App>, text: &[u8]) -> Result<Reply, String> {
    let request: Request = messages::parse(text)?;
    if let Request::Export { name } = &request {
        // An export writes the frame of the current edits: wait for it, then write.
        let version = *app.edits_version.borrow();
        let outcome = outcome_for(app, version).await;
        if !outcome.ok {
            return Err(format!("cannot export: the current frame failed ({})", outcome.json));
        }
        let app = app.clone();
        let name = name.clone();
        return tokio::task::spawn_blocking(move || {
            let engine = lock(&app.engine);
            let session = lock(&app.session);
            let computed = engine.last.as_ref().ok_or("nothing computed yet")?;
            let exported = export::export(&session, computed, &name)?;
            Ok(Reply::Now(serde_json::json!({ "type": "exported", "exported": exported }).to_string()))
        })
        .await
        .map_err(|e| format!("the export failed: {e}"))?;
    }
    // The version changes with the edits, under the session's lock (see `compute_latest`).
    let computed = lock(&app.brush_frame).clone();
    let mut session = lock(&app.session);
    if messages::apply(&mut session, &request, computed.as_deref())? {
        app.edits_version.send_modify(|v| *v += 1);
    }
    let version = *app.edits_version.borrow();
    drop(session);
    Ok(Reply::Wait(version))
}

/// The one compute worker: whenever the edits change, computes the latest of them (any versions
/// that arrived meanwhile are skipped) and publishes the outcome.
async fn compute_worker(app: Arc<App>, mut versions: watch::Receiver<u64>) {
    let mut done: Option<u64> = None;
    loop {
        versions.borrow_and_update();
        let task_app = app.clone();
        let outcome = tokio::task::spawn_blocking(move || compute_latest(&task_app, done)).await;
        let outcome = match outcome {
            Ok(Some(outcome)) => Some(outcome),
            Ok(None) => None,
            Err(e) => Some(Outcome {
                version: done.map_or(0, |v| v + 1),
                json: error_json(&format!("the computation failed: {e}")),
                ok: false,
            }),
        };
        if let Some(outcome) = outcome {
            done = Some(outcome.version);
            app.latest.send_replace(Some(Arc::new(outcome)));
        }
        if versions.changed().await.is_err() {
            return;
        }
    }
}

/// Computes the current edits, unless they are version `done`, already computed. The version is
/// read with the edits, under the session's lock (messages change both under it).
fn compute_latest(app: &App, done: Option<u64>) -> Option<Outcome> {
    let (version, edits, shot) = {
        let session = lock(&app.session);
        let version = *app.edits_version.borrow();
        if done == Some(version) {
            return None;
        }
        (version, session.edits.clone(), session.frame(&session.edits))
    };
    let fail = |message: String| Some(Outcome { version, json: error_json(&message), ok: false });
    let shot = match shot {
        Ok(shot) => shot,
        Err(message) => return fail(message),
    };
    let mut engine = lock(&app.engine);
    let Engine { deformer, last } = &mut *engine;
    let computed = match session::compute(deformer, shot) {
        Ok(computed) => computed,
        Err(message) => {
            // The deformer keeps nothing of a failed frame; start the next one afresh.
            *deformer = Deformer::new().keep_for_edits();
            *lock(&app.brush_frame) = None;
            return fail(message);
        }
    };
    // Locks are taken engine first, then session, everywhere both are held.
    let session = lock(&app.session);
    let view = FrameView::of(&session, &computed, version, edits.frame);
    drop(session);
    *lock(&app.brush_frame) = Some(Arc::new(BrushFrame::of(&computed, edits.frame)));
    *last = Some(computed);
    match serde_json::to_string(&serde_json::json!({ "type": "frame", "frame": view })) {
        Ok(json) => Some(Outcome { version, json, ok: true }),
        Err(e) => fail(format!("cannot write the frame as JSON: {e}")),
    }
}

async fn ws_handler(ws: WebSocketUpgrade, State(app): State<Arc<App>>) -> Response {
    ws.max_message_size(MAX_MESSAGE_BYTES)
        .max_frame_size(MAX_MESSAGE_BYTES)
        .on_upgrade(move |socket| websocket(socket, app))
}

/// One page's connection: its messages applied as they come, the latest frame sent whenever
/// one is computed (a frame computed while the previous one was still being sent replaces it).
async fn websocket(mut socket: WebSocket, app: Arc<App>) {
    let mut latest = app.latest.subscribe();
    let mut shutdown = app.shutdown.subscribe();
    latest.mark_changed();
    loop {
        tokio::select! {
            incoming = socket.recv() => {
                let text = match incoming {
                    Some(Ok(Message::Text(text))) => text.as_str().as_bytes().to_vec(),
                    Some(Ok(Message::Binary(_))) => {
                        let _ = socket.send(Message::text(error_json("binary messages are not accepted; send JSON text"))).await;
                        continue;
                    }
                    Some(Ok(_)) => continue,
                    Some(Err(_)) | None => return,
                };
                let answer = match handle(&app, &text).await {
                    Ok(Reply::Now(json)) => Some(json),
                    // The frame follows when computed.
                    Ok(Reply::Wait(_)) => None,
                    Err(message) => Some(error_json(&message)),
                };
                if let Some(json) = answer
                    && socket.send(Message::text(json)).await.is_err()
                {
                    return;
                }
            }
            changed = latest.changed() => {
                if changed.is_err() {
                    return;
                }
                let outcome = latest.borrow_and_update().clone();
                if let Some(outcome) = outcome
                    && socket.send(Message::text(outcome.json.clone())).await.is_err()
                {
                    return;
                }
            }
            _ = shutdown.changed() => {
                let _ = socket.send(Message::Close(None)).await;
                return;
            }
        }
    }
}
