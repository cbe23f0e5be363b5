//! The preview's HTTP server on 127.0.0.1 (tiny_http): the page, the state the page polls, each
//! frame as a binary message, edits, and saving them into the scene's file. The page asks for what it lacks, so a dropped
//! connection resumes with the next poll.

use std::io::Read;
use std::sync::{Arc, Mutex};

use serde_json::json;
use tiny_http::{Header, Method, Request, Response};

use super::preview_run::RunStatus;
use super::review;
use super::session::Session;

/// Request-handling threads: the page polls while it fetches frames.
const WORKERS: usize = 4;
/// The largest edit request read, bytes.
const MAX_EDIT_BYTES: u64 = 64 * 1024;

/// The page's files, served from the binary.
const PAGE: &[(&str, &str, &str)] = &[
    ("/", "text/html; charset=utf-8", include_str!("page/index.html")),
    ("/preview.js", "text/javascript; charset=utf-8", include_str!("page/preview.js")),
    ("/aim.js", "text/javascript; charset=utf-8", include_str!("page/aim.js")),
    ("/review.js", "text/javascript; charset=utf-8", include_str!("page/review.js")),
    ("/preview.css", "text/css; charset=utf-8", include_str!("page/preview.css")),
];

/// Serves `session` on `server` until the process ends.
pub fn serve(server: tiny_http::Server, session: Session) {
    let (server, session) = (Arc::new(server), Arc::new(Mutex::new(session)));
    let workers: Vec<_> = (0..WORKERS)
        .map(|_| {
            let (server, session) = (Arc::clone(&server), Arc::clone(&session));
            std::thread::spawn(move || {
                while let Ok(request) = server.recv() {
                    handle(request, &session);
                }
            })
        })
        .collect();
    for worker in workers {
        let _ = worker.join();
    }
}

/// Answers one request (a client gone before the answer is not an error of ours).
fn handle(mut request: Request, session: &Mutex<Session>) {
    let url = request.url().to_owned();
    let (path, query) = url.split_once('?').unwrap_or((&url, ""));
    let response = match (request.method(), path) {
        (Method::Get, "/api/state") => json_response(200, &state(session)),
        (Method::Get, "/api/frame") => frame(session, query),
        // the review's reads run outside the session's lock (the folder's reader has its own)
        (Method::Get, "/api/review") => answer(review::summary(&reviewed(session))),
        (Method::Get, "/api/review/frame") => answer(review::frame(&reviewed(session), query)),
        (Method::Get, "/api/review/image") => answer(review::image(&reviewed(session), query)),
        (Method::Get, "/api/review/pick") => answer(review::pick(&reviewed(session), query)),
        (Method::Post, "/api/edit") => edit(&mut request, session),
        (Method::Get, "/api/diff") => match lock(session).save_preview() {
            Ok((diff, _)) => json_response(200, &json!({ "diff": diff })),
            Err(message) => json_response(400, &json!({ "error": message })),
        },
        (Method::Post, "/api/save") => match lock(session).save() {
            Ok(path) => json_response(200, &json!({ "saved": path.display().to_string() })),
            Err(message) => json_response(500, &json!({ "error": message })),
        },
        (Method::Get, _) => match PAGE.iter().find(|(route, _, _)| *route == path) {
            Some((_, kind, body)) => Response::from_data(body.as_bytes()).with_header(header("Content-Type", kind)),
            None => text_response(404, "not found"),
        },
        _ => text_response(405, "method not allowed"),
    };
    let _ = request.respond(response);
}

/// The preview's state as the page shows it.
fn state(session: &Mutex<Session>) -> serde_json::Value {
    let mut session = lock(session);
    let target = session.target;
    let values: serde_json::Map<String, serde_json::Value> = session
        .scene
        .editable_values()
        .into_iter()
        .map(|(key, value)| (key, serde_json::to_value(value).unwrap_or_default()))
        .collect();
    let scene = session.scene.path.display().to_string();
    let error = session.error.clone();
    let run = session.run.as_mut().map(|run| {
        let status = run.status();
        let broken = run.folder.broken_bonds();
        run.saw_broken_bonds(&broken);
        let frames = run.folder.page_frames();
        json!({
            "generation": run.generation,
            "spacing_m": run.spacing_m,
            "frames": frames.count(),
            "lead_in_frames": frames.lead_in,
            "handoff": frames.handoff,
            "broken_bonds": broken,
            "seconds": run.seconds(),
            "first_break_s": run.first_break_s,
            "status": match &status { RunStatus::Running => "running", RunStatus::Finished => "finished", RunStatus::Failed(_) => "failed" },
            "failure": match status { RunStatus::Failed(log) => Some(log), _ => None },
        })
    });
    let bodies = bodies(&session.scene.config);
    let review = session.review.page_frames().count() > 0;
    json!({ "scene": scene, "target_particles": target, "values": values, "error": error, "run": run,
            "bodies": bodies, "review": review })
}

/// What the page draws besides the particles: the floor's height, the projectiles and indenters
/// (their start, velocity and radius), and the render camera where the scene places it.
fn bodies(config: &shatter_core::PipelineConfig) -> serde_json::Value {
    let sim = &config.sim;
    let projectiles = sim.projectile.iter().map(|p| (p.center_m, p.velocity_m_s, p.radius_m));
    let indenters = sim.indenter.iter().map(|i| (i.center_m, i.velocity_m_s, i.radius_m));
    let spheres: Vec<serde_json::Value> = projectiles
        .chain(indenters)
        .map(|(center_m, velocity_m_s, radius_m)| json!({ "center_m": center_m, "velocity_m_s": velocity_m_s, "radius_m": radius_m }))
        .collect();
    let camera = &config.render.camera;
    let [width, height] = config.render.resolution;
    let camera = camera.position_m.zip(camera.look_at_m).map(|(position_m, look_at_m)| {
        json!({ "position_m": position_m, "look_at_m": look_at_m, "up": camera.up, "fov_deg": camera.fov_deg,
                "aspect": f64::from(width) / f64::from(height.max(1)) })
    });
    json!({ "floor_height_m": sim.floor.as_ref().map(|floor| floor.height_m), "spheres": spheres, "camera": camera })
}

/// `GET /api/frame?generation=G&frame=F`: page frame F's message, or 404 while it is not there
/// (409 when the run asked for has been replaced, 503 when its files could not be read yet).
fn frame(session: &Mutex<Session>, query: &str) -> Response<std::io::Cursor<Vec<u8>>> {
    let number = |name: &str| review::query_number(query, name);
    let (Some(generation), Some(frame)) = (number("generation"), number("frame")) else {
        return text_response(400, "generation and frame are needed");
    };
    let folder = match &lock(session).run {
        Some(run) if run.generation == generation => run.folder.clone(),
        _ => return text_response(409, "that run has been replaced"),
    };
    let frames = folder.page_frames();
    if frame == 0 || frame > u64::from(frames.count()) {
        return text_response(404, "not there yet");
    }
    // a file being replaced or a log block not yet written: the page asks again at its next poll
    match folder.frame_message(&frames, frame as u32) {
        Ok(bytes) => Response::from_data(bytes).with_header(header("Content-Type", "application/octet-stream")),
        Err(message) => text_response(503, &message),
    }
}

/// `POST /api/edit` with `{"edits": {key: value}, "particles": N}`: a checked edit restarts
/// the preview; a refused one answers 400 with the CLI's message.
fn edit(request: &mut Request, session: &Mutex<Session>) -> Response<std::io::Cursor<Vec<u8>>> {
    let mut body = String::new();
    if request.as_reader().take(MAX_EDIT_BYTES).read_to_string(&mut body).is_err() {
        return text_response(400, "the edit is not UTF-8 text");
    }
    let parsed: Result<super::session::EditRequest, _> = serde_json::from_str(&body);
    let result = match parsed {
        Ok(edit) => lock(session).apply(edit),
        Err(error) => Err(format!("the edit is not understood: {error}")),
    };
    match result {
        Ok(generation) => json_response(200, &json!({ "generation": generation })),
        Err(message) => json_response(400, &json!({ "error": message })),
    }
}

/// The scene's output folder's reader.
fn reviewed(session: &Mutex<Session>) -> super::run_folder::RunFolder {
    lock(session).review.clone()
}

/// A review route's answer as a response.
fn answer((status, kind, body): review::Answer) -> Response<std::io::Cursor<Vec<u8>>> {
    Response::from_data(body)
        .with_status_code(status)
        .with_header(header("Content-Type", kind))
        .with_header(header("Cache-Control", "no-store"))
}

/// The session, whatever a panicking worker left (its state stays consistent between requests).
fn lock(session: &Mutex<Session>) -> std::sync::MutexGuard<'_, Session> {
    session.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A header of ours (ASCII names and values).
fn header(name: &str, value: &str) -> Header {
    Header::from_bytes(name.as_bytes(), value.as_bytes()).expect("our headers are ASCII")
}

fn json_response(status: u16, value: &serde_json::Value) -> Response<std::io::Cursor<Vec<u8>>> {
    Response::from_data(value.to_string().into_bytes())
        .with_status_code(status)
        .with_header(header("Content-Type", "application/json"))
        .with_header(header("Cache-Control", "no-store"))
}

fn text_response(status: u16, text: &str) -> Response<std::io::Cursor<Vec<u8>>> {
    Response::from_data(text.as_bytes().to_vec())
        .with_status_code(status)
        .with_header(header("Content-Type", "text/plain; charset=utf-8"))
}
