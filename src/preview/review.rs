//! Review of the scene's own output folder, finished or still being written (a farm job's): its
//! shot's frames, the bonds broken and the kinetic energy per simulation frame, its rendered
//! frames' passes and the Cryptomatte pick under the cursor. Read as a reader of the folder reads
//! it: never its writer's lock, every file whole or not yet there.

use serde_json::json;
use shatter_render::cryptomatte::{FRAGMENT_MATTE, MATERIAL_MATTE};
use shatter_render::frame_review::ReviewPass;

use super::run_folder::RunFolder;

/// What a route answers: status, content type, body.
pub type Answer = (u16, &'static str, Vec<u8>);

fn json_answer(status: u16, value: &serde_json::Value) -> Answer {
    (status, "application/json", value.to_string().into_bytes())
}

fn text_answer(status: u16, text: &str) -> Answer {
    (status, "text/plain; charset=utf-8", text.as_bytes().to_vec())
}

/// The unsigned number `name` of a query string.
pub fn query_number(query: &str, name: &str) -> Option<u64> {
    query_text(query, name)?.parse().ok()
}

/// The value `name` of a query string (plain ASCII values, as the page sends them).
pub fn query_text<'a>(query: &'a str, name: &str) -> Option<&'a str> {
    query.split('&').find_map(|pair| pair.strip_prefix(name)?.strip_prefix('='))
}

/// `GET /api/review`: the folder's frames, the bonds broken and the kinetic energy per
/// simulation frame, and which shot frames are rendered.
pub fn summary(folder: &RunFolder) -> Answer {
    let frames = folder.page_frames();
    let energy = match folder.kinetic_energy_j(frames.sim) {
        Ok(energy) => energy,
        Err(message) => return text_answer(503, &message),
    };
    json_answer(
        200,
        &json!({
            "output_dir": folder.root().display().to_string(),
            "frames": frames.count(),
            "lead_in_frames": frames.lead_in,
            "handoff": frames.handoff,
            "broken_bonds": folder.broken_bonds(),
            "kinetic_energy_j": energy,
            "rendered": folder.rendered_frames(&frames),
        }),
    )
}

/// `GET /api/review/frame?frame=F`: shot frame F's message.
pub fn frame(folder: &RunFolder, query: &str) -> Answer {
    let Some(frame) = query_number(query, "frame").and_then(|f| u32::try_from(f).ok()) else {
        return text_answer(400, "frame is needed");
    };
    let frames = folder.page_frames();
    if frame == 0 || frame > frames.count() {
        return text_answer(404, "not there yet");
    }
    match folder.frame_message(&frames, frame) {
        Ok(bytes) => (200, "application/octet-stream", bytes),
        Err(message) => text_answer(503, &message),
    }
}

/// `GET /api/review/image?frame=F&pass=beauty|depth|normal|motion`: the rendered frame's pass as
/// a PNG.
pub fn image(folder: &RunFolder, query: &str) -> Answer {
    let frame = query_number(query, "frame").and_then(|f| u32::try_from(f).ok());
    let pass = query_text(query, "pass").and_then(ReviewPass::parse);
    let (Some(frame), Some(pass)) = (frame, pass) else {
        return text_answer(400, "frame and pass (beauty, depth, normal or motion) are needed");
    };
    let rendered = match folder.rendered(frame) {
        Ok(rendered) => rendered,
        Err(message) => return text_answer(404, &message),
    };
    match rendered.pass_png(pass) {
        Some(png) => (200, "image/png", png),
        None => text_answer(404, "the frame has no such pass"),
    }
}

/// `GET /api/review/pick?frame=F&x=X&y=Y`: the pieces and materials the frame's Cryptomattes
/// hold at pixel (X, Y), each with its coverage, most covered first.
pub fn pick(folder: &RunFolder, query: &str) -> Answer {
    let frame = query_number(query, "frame").and_then(|f| u32::try_from(f).ok());
    let (x, y) = (query_number(query, "x"), query_number(query, "y"));
    let (Some(frame), Some(x), Some(y)) = (frame, x, y) else {
        return text_answer(400, "frame, x and y are needed");
    };
    let rendered = match folder.rendered(frame) {
        Ok(rendered) => rendered,
        Err(message) => return text_answer(404, &message),
    };
    let (x, y) = (x as usize, y as usize);
    json_answer(
        200,
        &json!({
            "pieces": rendered.pick(FRAGMENT_MATTE, x, y),
            "materials": rendered.pick(MATERIAL_MATTE, x, y),
        }),
    )
}
