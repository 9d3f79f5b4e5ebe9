//! Pictures of a shot: PNG renders of chosen frames (`DIR/preview/<frame:04>.png`), the same
//! frame as "input | output" side by side (`<frame:04>_compare.png`), and strips of several
//! frames, all with the software rasterizer of `squish-render`.
//!
//! One camera serves the whole shot — it frames every object over every computed frame — so
//! that pictures of different frames compare directly. Objects get distinct neutral tints;
//! the output can be coloured by the contact region 𝒞, the deformable region 𝒟 or the radial
//! parameter u, and the input shows the intersection regions, so the pair reads as "what went
//! in (red: overlapping) → what came out (blue: in contact, green: bulging)".

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};

use glam::DVec3;
use rayon::prelude::*;
use squish::TriMesh;
use squish_render::{
    Camera, Image, Label, RenderMesh, RenderOptions, Rgb, draw_line, draw_text, encode_png, grid, label,
    orbit_direction, render, scalar_colors, srgb8, text_size,
};

use squish_shot::ShotError;
use squish_shot::files::{create_dir, write_bytes};
use squish_shot::shot::{PreviewFrame, ShotOutcome};

use crate::error::CliError;

/// How to colour the output meshes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum ColorMode {
    /// The contact region 𝒞 in blue.
    Contact,
    /// The contact region in blue and the deformable region 𝒟 (the bulge) in green.
    #[default]
    Deformable,
    /// The radial parameter u from 0 (contact boundary) to 1 (end of the deformation).
    U,
    /// Plain tints, one per object.
    None,
}

/// The world's up axis, for the camera.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum UpAxis {
    /// z up (Blender's world, the procedural scenes).
    #[default]
    Z,
    /// y up (glTF, Maya, Houdini, most OBJ exports).
    Y,
}

/// The `--up` choice: an axis, or `auto` — y for glTF inputs (y-up by definition), z for OBJ
/// and PLY (unless a scene's `preview.up` says otherwise).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum UpChoice {
    #[default]
    Auto,
    Y,
    Z,
}

impl UpChoice {
    /// The axis: the choice, else `declared` (a scene's `preview.up`), else y when any input is
    /// glTF, else z.
    pub fn resolve(self, declared: Option<UpAxis>, any_gltf: bool) -> UpAxis {
        match self {
            Self::Y => UpAxis::Y,
            Self::Z => UpAxis::Z,
            Self::Auto => declared.unwrap_or(if any_gltf { UpAxis::Y } else { UpAxis::Z }),
        }
    }
}

/// What the default camera frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Framing {
    /// The contact regions and what deforms around them (everything when nothing touches).
    #[default]
    Contact,
    /// Every object, whole.
    All,
}

/// A camera given by the user (a scene's `preview.camera`): where it is, what it looks at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraPlacement {
    pub eye: DVec3,
    pub target: DVec3,
    /// Default: the world's up axis.
    pub up: Option<DVec3>,
    /// Vertical field of view in degrees. Default 35.
    pub fov_deg: Option<f64>,
}

/// Parses `--size WxH` (each side 16 to 8192 pixels).
pub fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let (w, h) =
        text.split_once(['x', 'X']).ok_or_else(|| format!("'{text}': give the size as WIDTHxHEIGHT, e.g. 1280x720"))?;
    let side = |s: &str| -> Result<u32, String> {
        let v: u32 = s.trim().parse().map_err(|_| format!("'{text}': '{s}' is not a whole number of pixels"))?;
        if (16..=8192).contains(&v) { Ok(v) } else { Err(format!("'{text}': each side must be 16 to 8192 pixels")) }
    };
    Ok((side(w)?, side(h)?))
}

impl UpAxis {
    /// A z-up direction expressed in this world (a rotation taking +z to the up axis).
    fn rotated_from_z_up(self, v: DVec3) -> DVec3 {
        match self {
            Self::Z => v,
            Self::Y => DVec3::new(v.x, v.z, -v.y),
        }
    }
}

/// Picture settings.
#[derive(Clone, Copy, Debug)]
pub struct PictureSettings {
    pub width: u32,
    pub height: u32,
    pub color: ColorMode,
    pub up: UpAxis,
    /// Orbit angles of the camera in degrees (see `squish_render::orbit_direction`).
    pub azimuth: f64,
    pub elevation: f64,
    /// What the default camera frames.
    pub framing: Framing,
    /// A camera given by the user, used instead of the framed one.
    pub camera: Option<CameraPlacement>,
}

impl Default for PictureSettings {
    fn default() -> Self {
        // Slightly above and to the side: contacts between stacked objects stay visible at the
        // silhouette, and the bulge shows against the background.
        Self {
            width: 640,
            height: 480,
            color: ColorMode::default(),
            up: UpAxis::Z,
            azimuth: 30.0,
            elevation: 12.0,
            framing: Framing::All,
            camera: None,
        }
    }
}

const FOV_DEG: f64 = 35.0;

/// Neutral tints that tell objects apart without competing with the label colours.
fn tint(object: usize) -> Rgb {
    const TINTS: [[u8; 3]; 4] = [[0xd2, 0xc8, 0xb8], [0xb0, 0xba, 0xc8], [0xc8, 0xb8, 0xc8], [0xbc, 0xc8, 0xb4]];
    let [r, g, b] = TINTS[object % TINTS.len()];
    srgb8(r, g, b)
}

/// The camera and the section plane shared by every picture of a shot.
#[derive(Clone, Copy, Debug)]
pub struct ShotView {
    pub camera: Camera,
    /// A point of the section plane and its normal, pointing away from the camera: the
    /// section views keep what lies beyond the plane.
    pub section: (DVec3, DVec3),
}

/// The view of a shot: a camera framing every object over the whole shot (the extreme vertices
/// of every computed frame, and all vertices of the previewed frames, inputs and outputs) — or,
/// with [`Framing::Contact`], the neighbourhood of the previewed frames' contacts — unless the
/// settings give one, and a vertical section plane facing the camera through the contacts.
pub fn shot_view(outcome: &ShotOutcome, settings: &PictureSettings) -> ShotView {
    let support: Vec<DVec3> = outcome.records.iter().flat_map(|r| r.support.iter().copied()).collect();
    let previews: Vec<&PreviewFrame> = outcome.previews.values().collect();
    view_of(&previews, support, settings)
}

/// The view of some previewed frames (see [`shot_view`]); `points` are more points to frame.
pub fn view_of(previews: &[&PreviewFrame], mut points: Vec<DVec3>, settings: &PictureSettings) -> ShotView {
    let mut contact_sum = DVec3::ZERO;
    let mut contact_count = 0usize;
    // Vertices of the contacts, of what deforms around them and of the input's overlaps.
    let mut near_contact: Vec<DVec3> = Vec::new();
    // Where objects with self-contact cross themselves in the input (beyond the rest pose's own).
    let mut self_crossing: Vec<DVec3> = Vec::new();
    for p in previews {
        for (i, input) in p.inputs.iter().enumerate() {
            if p.self_intersection_left.get(i).is_some_and(|left| !left.is_empty()) {
                let flags = &p.intersection[i];
                self_crossing.extend(input.positions.iter().zip(flags).filter(|(_, f)| **f).map(|(q, _)| *q));
            }
        }
        for mesh in p.inputs.iter().chain(&p.outputs) {
            points.extend_from_slice(&mesh.positions);
        }
        for (mesh, contact) in p.outputs.iter().zip(&p.contact) {
            for (q, _) in mesh.positions.iter().zip(contact.iter().flatten()).filter(|(_, c)| **c) {
                contact_sum += *q;
                contact_count += 1;
            }
        }
        for (i, mesh) in p.outputs.iter().enumerate() {
            let flags = [p.contact[i].as_deref(), p.deformable[i].as_deref(), Some(p.intersection[i].as_slice())];
            for (v, q) in mesh.positions.iter().enumerate() {
                if flags.iter().flatten().any(|f| f.get(v).copied().unwrap_or(false)) {
                    near_contact.push(*q);
                }
            }
        }
    }
    let view = settings.up.rotated_from_z_up(orbit_direction(settings.azimuth, settings.elevation));
    let up = settings.up.rotated_from_z_up(DVec3::Z);
    let aspect = f64::from(settings.width) / f64::from(settings.height);
    let framed = match settings.framing {
        // A character's self-contacts move much of it: frame where it crosses itself.
        Framing::Contact if !self_crossing.is_empty() => contact_neighbourhood(&self_crossing, &points),
        Framing::Contact if !near_contact.is_empty() => contact_neighbourhood(&near_contact, &points),
        _ => points,
    };
    let mut camera = match settings.camera {
        Some(c) => Camera::look_at(c.eye, c.target, c.up.unwrap_or(up), c.fov_deg.unwrap_or(FOV_DEG), aspect),
        None => {
            let mut camera = Camera::framing_points(&framed, view, up, FOV_DEG, aspect);
            // A wider lens than the fit leaves a margin for the caption and the legend.
            camera.fov_y_deg *= 1.12;
            camera
        }
    };
    if settings.camera.is_some() {
        camera.aspect = aspect;
    }
    let view = (camera.target - camera.eye).normalize_or_zero();
    let horizontal = (view - up * view.dot(up)).normalize_or_zero();
    let normal = if horizontal == DVec3::ZERO { view } else { horizontal };
    // A character crosses itself in several places at once (both armpits, both knees): the
    // section goes through the densest of them rather than through their mean, the body's middle.
    let point = match densest_cluster(&self_crossing) {
        Some(centre) => centre,
        None if contact_count > 0 => contact_sum / contact_count as f64,
        None => camera.target,
    };
    ShotView { camera, section: (point, normal) }
}

/// The mean of the points in the cell of a grid over their box (8 cells along its longest side)
/// that holds the most of them (ties: the first cell in x, y, z order); `None` without points.
fn densest_cluster(points: &[DVec3]) -> Option<DVec3> {
    if points.is_empty() {
        return None;
    }
    let region = squish::mesh::Aabb3::from_points(points.iter().copied());
    let size = region.extent().max_element() / 8.0;
    if !size.is_finite() || size <= 0.0 {
        return Some(points[0]);
    }
    let cell = |q: DVec3| {
        let c = ((q - region.min) / size).floor().min(DVec3::splat(7.0));
        (c.x as u32, c.y as u32, c.z as u32)
    };
    let mut cells: std::collections::BTreeMap<(u32, u32, u32), (usize, DVec3)> = std::collections::BTreeMap::new();
    for &q in points {
        let entry = cells.entry(cell(q)).or_insert((0, DVec3::ZERO));
        entry.0 += 1;
        entry.1 += q;
    }
    let mut best: Option<(usize, DVec3)> = None;
    for &(count, sum) in cells.values() {
        if best.is_none_or(|(n, _)| count > n) {
            best = Some((count, sum));
        }
    }
    best.map(|(count, sum)| sum / count as f64)
}

/// The points to frame around a contact: the box of the contact's points, grown about its
/// centre to at least a third of the whole scene's size (so that the objects stay recognizable),
/// as its eight corners.
fn contact_neighbourhood(contact: &[DVec3], all: &[DVec3]) -> Vec<DVec3> {
    let whole = squish::mesh::Aabb3::from_points(all.iter().copied());
    let region = squish::mesh::Aabb3::from_points(contact.iter().copied());
    let least = whole.extent() / 3.0;
    let half = (0.5 * region.extent() * 1.3).max(0.5 * least.min(DVec3::splat(least.max_element())));
    let centre = region.center();
    (0..8)
        .map(|i| {
            let sign = DVec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            );
            centre + sign * half
        })
        .collect()
}

/// Which meshes of a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    Input,
    Output,
}

/// The meshes of one side of a frame with their colours, whole or cut by the section plane.
fn coloured_meshes(p: &PreviewFrame, side: Side, mode: ColorMode, section: Option<(DVec3, DVec3)>) -> Vec<Section> {
    let meshes = match side {
        Side::Input => &p.inputs,
        Side::Output => &p.outputs,
    };
    meshes
        .iter()
        .enumerate()
        .map(|(i, mesh)| {
            let colors = vertex_colors(p, i, side, mode);
            match section {
                Some((point, normal)) => cut(mesh, &colors, point, normal),
                None => Section { mesh: mesh.clone(), colors, profile: Vec::new() },
            }
        })
        .collect()
}

/// Renders one side of a frame, captioned, with a colour legend.
pub fn render_frame(
    frame: i64,
    p: &PreviewFrame,
    side: Side,
    section: bool,
    view: &ShotView,
    settings: &PictureSettings,
    caption: &str,
) -> Result<Image, ShotError> {
    let meshes = coloured_meshes(p, side, settings.color, section.then_some(view.section));
    let scene: Vec<RenderMesh> =
        meshes.iter().map(|s| RenderMesh::new(&s.mesh).with_vertex_colors(&s.colors)).collect();
    let mut options = RenderOptions::new(settings.width, settings.height);
    options.supersampling = 2;
    if section {
        // Inside surfaces seen through the cut: darker and neutral rather than the default
        // magenta, which would read as a label colour.
        options.lighting.back_tint = [0.05, 0.05, 0.06];
        options.lighting.back_tint_amount = 0.55;
    }
    let mut image = render(&scene, &view.camera, &options)
        .map_err(|e| ShotError::Internal(format!("frame {frame}: picture: {e}")))?;
    draw_profiles(&mut image, &meshes, &view.camera);
    label(&mut image, caption);
    let entries: Vec<(Rgb, &str)> = match (side, settings.color) {
        (Side::Input, _) => vec![(Label::Intersection.color(), "intersection")],
        (Side::Output, ColorMode::Contact) => vec![(Label::Contact.color(), "contact")],
        (Side::Output, ColorMode::Deformable) => {
            vec![(Label::Contact.color(), "contact"), (Label::Deformable.color(), "deformable (fades with u)")]
        }
        (Side::Output, ColorMode::U) => {
            let ends = scalar_colors(&[0.0, 1.0], Some((0.0, 1.0)));
            vec![(ends[0], "u = 0 (contact boundary)"), (ends[1], "u = 1 (end of deformation)")]
        }
        (Side::Output, ColorMode::None) => Vec::new(),
    };
    let mut entries = entries;
    if side == Side::Output && p.self_intersection_left.iter().flatten().any(|&left| left) {
        entries.push((Label::Intersection.color(), "still self-intersecting"));
    }
    legend(&mut image, &entries);
    Ok(image)
}

/// Linear interpolation of two colours.
fn mix(a: Rgb, b: Rgb, t: f32) -> Rgb {
    [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t]
}

/// Per-vertex colours of object `i`.
fn vertex_colors(p: &PreviewFrame, i: usize, side: Side, mode: ColorMode) -> Vec<Rgb> {
    let base = tint(i);
    let n = match side {
        Side::Input => p.inputs[i].num_vertices(),
        Side::Output => p.outputs[i].num_vertices(),
    };
    let mut colors = vec![base; n];
    match side {
        Side::Input => {
            for (c, &inside) in colors.iter_mut().zip(&p.intersection[i]) {
                if inside {
                    *c = Label::Intersection.color();
                }
            }
        }
        Side::Output => match mode {
            ColorMode::None => {}
            ColorMode::Contact | ColorMode::Deformable => {
                if mode == ColorMode::Deformable
                    && let (Some(deformable), Some(u)) = (&p.deformable[i], &p.u[i])
                {
                    // The deformation fades out from the contact boundary (u = 0) to the end of
                    // the deformable region (u = 1): so does the colour.
                    for ((c, &d), &u) in colors.iter_mut().zip(deformable).zip(u) {
                        if d && u.is_finite() {
                            let u = u.clamp(0.0, 1.0) as f32;
                            *c = mix(Label::Deformable.color(), base, u * u);
                        }
                    }
                }
                if let Some(contact) = &p.contact[i] {
                    for (c, &k) in colors.iter_mut().zip(contact) {
                        if k {
                            *c = Label::Contact.color();
                        }
                    }
                }
            }
            ColorMode::U => {
                if let Some(u) = &p.u[i] {
                    let mapped = scalar_colors(u, Some((0.0, 1.0)));
                    for ((c, &value), m) in colors.iter_mut().zip(u).zip(mapped) {
                        if value.is_finite() && value <= 1.0 {
                            *c = m;
                        }
                    }
                }
            }
        },
    }
    if side == Side::Output
        && let Some(left) = p.self_intersection_left.get(i)
    {
        for (c, &still) in colors.iter_mut().zip(left) {
            if still {
                *c = Label::Intersection.color();
            }
        }
    }
    colors
}

/// The part of `mesh` beyond the plane through `point` with normal `normal` (signed distance
/// ≥ 0), triangles crossing the plane clipped exactly so the cut is a clean line. Cut points
/// are shared by the two triangles of their edge, so shading stays smooth up to the cut.
fn cut(mesh: &TriMesh, colors: &[Rgb], point: DVec3, normal: DVec3) -> Section {
    let distance: Vec<f64> = mesh.positions.iter().map(|p| (*p - point).dot(normal)).collect();
    let mut positions = mesh.positions.clone();
    let mut out_colors = colors.to_vec();
    let mut cut_points: HashMap<(u32, u32), u32> = HashMap::new();
    let mut triangles = Vec::with_capacity(mesh.triangles.len());
    let mut profile = Vec::new();
    // Per cut point: the colour of the nearer end of its edge (labels are per vertex).
    let mut nearest: Vec<Rgb> = Vec::new();
    for tri in &mesh.triangles {
        let kept = tri.iter().filter(|&&v| distance[v as usize] >= 0.0).count();
        if kept == 3 {
            triangles.push(*tri);
            continue;
        }
        if kept == 0 {
            continue;
        }
        // Sutherland–Hodgman against one plane: a triangle becomes a triangle or a quad.
        let mut polygon: Vec<u32> = Vec::with_capacity(4);
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            let (da, db) = (distance[a as usize], distance[b as usize]);
            if da >= 0.0 {
                polygon.push(a);
            }
            if (da >= 0.0) != (db >= 0.0) {
                let key = (a.min(b), a.max(b));
                let index = *cut_points.entry(key).or_insert_with(|| {
                    let (lo, hi) = key;
                    let (dl, dh) = (distance[lo as usize], distance[hi as usize]);
                    let t = dl / (dl - dh);
                    positions.push(mesh.positions[lo as usize].lerp(mesh.positions[hi as usize], t));
                    out_colors.push(mix(colors[lo as usize], colors[hi as usize], t as f32));
                    nearest.push(colors[if t < 0.5 { lo } else { hi } as usize]);
                    (positions.len() - 1) as u32
                });
                polygon.push(index);
            }
        }
        for k in 1..polygon.len().saturating_sub(1) {
            triangles.push([polygon[0], polygon[k], polygon[k + 1]]);
        }
        let on_plane: Vec<u32> = polygon.iter().copied().filter(|&v| v as usize >= mesh.num_vertices()).collect();
        if let [a, b] = on_plane[..] {
            let label = |v: u32| nearest[v as usize - mesh.num_vertices()];
            let (ca, cb) = (label(a), label(b));
            let strong = [Label::Contact.color(), Label::Intersection.color()];
            let color = if ca == cb && strong.contains(&ca) { ca } else { PROFILE_COLOR };
            profile.push(([a, b], color));
        }
    }
    Section { mesh: TriMesh { positions, triangles }, colors: out_colors, profile }
}

/// A mesh cut by a plane: the part kept, its colours, and the profile — segments between cut
/// points, on the plane.
struct Section {
    mesh: TriMesh,
    colors: Vec<Rgb>,
    /// Segments and their colours: contact and intersection stretches in their label colour,
    /// the rest dark, so the outlines read like a technical section.
    profile: Vec<([u32; 2], Rgb)>,
}

/// Colour of unlabelled section outlines.
const PROFILE_COLOR: Rgb = [0.02, 0.02, 0.025];

/// Draws the section profiles over a picture: nothing lies between the camera and the section
/// plane, so the profiles are never hidden.
fn draw_profiles(image: &mut Image, sections: &[Section], camera: &Camera) {
    let scale = f64::from((image.height / 300).clamp(1, 3));
    for section in sections {
        for &([a, b], color) in &section.profile {
            let (pa, pb) = (section.mesh.positions[a as usize], section.mesh.positions[b as usize]);
            let (Some(qa), Some(qb)) =
                (camera.project(pa, image.width, image.height), camera.project(pb, image.width, image.height))
            else {
                continue;
            };
            draw_line(image, (qa.x, qa.y), (qb.x, qb.y), 1.5 * scale, color, 1.0);
        }
    }
}

/// Colour swatches with names in the bottom-left corner.
fn legend(image: &mut Image, entries: &[(Rgb, &str)]) {
    if entries.is_empty() {
        return;
    }
    let scale = (image.height / 300).clamp(1, 3);
    let (_, h) = text_size("M", scale);
    let row = i64::from(h) + 4 * i64::from(scale);
    let width = entries.iter().map(|(_, n)| text_size(n, scale).0).max().unwrap_or(0) + h + 12 * scale;
    let height = row * entries.len() as i64 + 4 * i64::from(scale);
    let top = i64::from(image.height) - height;
    image.blend_rect(0, top, width, height as u32, [0.0; 3], 0.55);
    for (k, (color, name)) in entries.iter().enumerate() {
        let y = top + 4 * i64::from(scale) + k as i64 * row;
        image.blend_rect(4 * i64::from(scale), y, h, h, *color, 1.0);
        draw_text(image, 4 * i64::from(scale) + i64::from(h) + 4 * i64::from(scale), y, name, [1.0; 3], 1.0, scale);
    }
}

/// The pictures of one frame: the output whole and cut through the contacts, and the
/// comparison "input | output", whole (top) and cut (bottom).
pub struct FramePictures {
    pub output: Image,
    pub section: Image,
    pub compare: Image,
}

/// Renders the pictures of one previewed frame (`frame`: the shot's frame number, for the
/// captions; `None` for a single frame).
pub fn frame_pictures(
    frame: Option<i64>,
    p: &PreviewFrame,
    view: &ShotView,
    settings: &PictureSettings,
) -> Result<FramePictures, ShotError> {
    let title = frame.map_or_else(String::new, |f| format!("frame {f}: "));
    let frame = frame.unwrap_or(0);
    let input = render_frame(frame, p, Side::Input, false, view, settings, &format!("{title}input"))?;
    let output = render_frame(frame, p, Side::Output, false, view, settings, &format!("{title}output"))?;
    let input_section = render_frame(frame, p, Side::Input, true, view, settings, "section: input")?;
    let section = render_frame(frame, p, Side::Output, true, view, settings, &format!("{title}section"))?;
    let compare = grid(&[&input, &output, &input_section, &section], 2, 4, [255, 255, 255, 255]);
    Ok(FramePictures { output, section, compare })
}

/// Half the size: each pixel the average of a 2 × 2 block (in sRGB bytes: close enough for a
/// thumbnail, and exact for flat areas).
pub fn half_size(image: &Image) -> Image {
    let (w, h) = ((image.width / 2).max(1), (image.height / 2).max(1));
    let mut out = Image::new(w, h, [0, 0, 0, 0]);
    for y in 0..h {
        for x in 0..w {
            let mut sum = [0u32; 4];
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                if let Some(p) = image.pixel((2 * x + dx).min(image.width - 1), (2 * y + dy).min(image.height - 1)) {
                    for c in 0..4 {
                        sum[c] += u32::from(p[c]);
                    }
                }
            }
            out.set_pixel(x, y, sum.map(|s| ((s + 2) / 4) as u8));
        }
    }
    out
}

/// A frame's picture files and its pictures.
struct WrittenFrame {
    frame: i64,
    files: [PathBuf; 2],
    pictures: FramePictures,
}

/// Writes `dir/<frame:04>.png` (the output) and `dir/<frame:04>_compare.png` for every
/// previewed frame; returns the files written and the pictures, by frame.
pub fn write_previews(
    dir: &Path,
    outcome: &ShotOutcome,
    settings: &PictureSettings,
) -> Result<(Vec<PathBuf>, BTreeMap<i64, FramePictures>), ShotError> {
    let mut written = Vec::new();
    let mut outputs = BTreeMap::new();
    if outcome.previews.is_empty() {
        return Ok((written, outputs));
    }
    create_dir(dir)?;
    let view = shot_view(outcome, settings);
    // Frames in parallel: PNG encoding is sequential within a picture.
    let done: Vec<Result<WrittenFrame, ShotError>> = outcome
        .previews
        .par_iter()
        .map(|(&frame, p)| {
            let name = squish_io::scene::format_frame(frame, 4);
            let pictures = frame_pictures(Some(frame), p, &view, settings)?;
            let files = [
                write_png(&dir.join(format!("{name}.png")), &pictures.output)?,
                write_png(&dir.join(format!("{name}_compare.png")), &pictures.compare)?,
            ];
            Ok(WrittenFrame { frame, files, pictures })
        })
        .collect();
    for result in done {
        let WrittenFrame { frame, files, pictures } = result?;
        written.extend(files);
        outputs.insert(frame, pictures);
    }
    Ok((written, outputs))
}

/// The picture options shared by `deform`, `contact` and `run`.
#[derive(clap::Args, Debug, Clone)]
pub struct PictureArgs {
    /// Up axis of the pictures: auto (y for glTF inputs, which are y-up; z for OBJ and PLY), y or z.
    #[arg(long, value_enum, default_value_t = UpChoice::Auto)]
    pub up: UpChoice,
    /// Picture size, WIDTHxHEIGHT (default 640x480, or a scene's `preview.size`).
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// What the camera frames: the contact and its surroundings, or every object whole.
    #[arg(long, value_enum, default_value_t = Framing::Contact)]
    pub framing: Framing,
}

/// What a scene file says about its pictures (`preview = { camera, size, up }`); the
/// command-line options win over it.
#[derive(Clone, Copy, Debug, Default)]
pub struct SceneDefaults {
    pub up: Option<UpAxis>,
    pub size: Option<(u32, u32)>,
    pub camera: Option<CameraPlacement>,
}

impl PictureArgs {
    /// Picture settings for these options over a scene's defaults; `any_gltf`: whether an input
    /// is glTF (for `--up auto`).
    pub fn settings(&self, color: ColorMode, defaults: &SceneDefaults, any_gltf: bool) -> PictureSettings {
        let (width, height) = self.size.or(defaults.size).unwrap_or((640, 480));
        PictureSettings {
            width,
            height,
            color,
            up: self.up.resolve(defaults.up, any_gltf),
            framing: self.framing,
            camera: defaults.camera,
            ..PictureSettings::default()
        }
    }
}

/// Writes the "input | output" picture of a single frame (whole, and cut through the contact)
/// to `path`.
pub fn write_frame_preview(path: &Path, p: &PreviewFrame, settings: &PictureSettings) -> Result<PathBuf, ShotError> {
    let view = view_of(&[p], Vec::new(), settings);
    let pictures = frame_pictures(None, p, &view, settings)?;
    write_png(path, &pictures.compare)
}

/// Half-size thumbnails of the frames: the outputs in the top row, their sections below.
pub fn strip(pictures: &BTreeMap<i64, FramePictures>) -> Option<Image> {
    if pictures.is_empty() {
        return None;
    }
    let thumbnails: Vec<Image> = pictures
        .values()
        .map(|p| half_size(&p.output))
        .chain(pictures.values().map(|p| half_size(&p.section)))
        .collect();
    let refs: Vec<&Image> = thumbnails.iter().collect();
    Some(grid(&refs, pictures.len(), 4, [255, 255, 255, 255]))
}

/// Encodes and writes a PNG atomically.
pub fn write_png(path: &Path, image: &Image) -> Result<PathBuf, ShotError> {
    let bytes = encode_png(image).map_err(|e| ShotError::Internal(format!("{}: {e}", path.display())))?;
    write_bytes(path, &bytes)?;
    Ok(path.to_path_buf())
}

/// Frames to preview: `auto` = first, middle and last of `range`; otherwise a comma-separated
/// list of frames and `A:B` ranges, each inside `range`.
pub fn preview_frames(text: &str, range: &std::ops::RangeInclusive<i64>) -> Result<BTreeSet<i64>, CliError> {
    let (start, end) = (*range.start(), *range.end());
    if text.trim() == "auto" {
        let middle = ((start as i128 + end as i128) / 2) as i64;
        return Ok([start, middle, end].into_iter().collect());
    }
    let bounds = squish_io::scene::FrameRange { start, end, fps: 24.0 };
    let mut frames = BTreeSet::new();
    for item in text.split(',') {
        let selection = squish_io::parse_frame_selection(item.trim(), &bounds)
            .map_err(|e| CliError::input(format!("--preview={}: {}", e.text, e.message)))?;
        frames.extend(selection);
    }
    Ok(frames)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use super::*;

    #[test]
    fn preview_selections() {
        let range = 1..=48;
        assert_eq!(preview_frames("auto", &range).unwrap().into_iter().collect::<Vec<_>>(), vec![1, 24, 48]);
        assert_eq!(preview_frames("3, 10:12", &range).unwrap().into_iter().collect::<Vec<_>>(), vec![3, 10, 11, 12]);
        let err = preview_frames("60", &range).unwrap_err().to_string();
        assert!(err.contains("--preview") && err.contains("1:48"), "{err}");
    }

    #[test]
    fn the_section_keeps_the_far_side_with_a_clean_cut() {
        let mesh = squish::mesh::shapes::icosphere(1.0, 2);
        let colors = vec![[0.5; 3]; mesh.num_vertices()];
        let Section { mesh: cut_mesh, colors: cut_colors, profile } = cut(&mesh, &colors, DVec3::ZERO, DVec3::X);
        // The profile is a closed loop: every cut point ends two segments.
        let mut ends = vec![0; cut_mesh.num_vertices()];
        for ([a, b], _) in profile {
            ends[a as usize] += 1;
            ends[b as usize] += 1;
        }
        assert!(ends[mesh.num_vertices()..].iter().all(|&n| n == 2), "{ends:?}");
        assert_eq!(cut_colors.len(), cut_mesh.num_vertices());
        for tri in &cut_mesh.triangles {
            for &v in tri {
                assert!(cut_mesh.positions[v as usize].x >= -1e-12);
            }
        }
        // The cut runs along the plane: points on it, on the unit circle x = 0.
        let on_plane: Vec<_> = cut_mesh.positions[mesh.num_vertices()..].to_vec();
        assert!(!on_plane.is_empty());
        for p in on_plane {
            assert!(p.x.abs() < 1e-12 && (p.length() - 1.0).abs() < 0.05, "{p}");
        }
        // About half the area is left.
        let area = |m: &TriMesh| squish::mesh::face_areas(m).iter().sum::<f64>();
        let ratio = area(&cut_mesh) / area(&mesh);
        assert!((ratio - 0.5).abs() < 0.01, "{ratio}");
    }

    #[test]
    fn half_size_averages_blocks() {
        let mut image = Image::new(4, 2, [0, 0, 0, 255]);
        image.set_pixel(0, 0, [200, 100, 0, 255]);
        let half = half_size(&image);
        assert_eq!((half.width, half.height), (2, 1));
        assert_eq!(half.pixel(0, 0), Some([50, 25, 0, 255]));
        assert_eq!(half.pixel(1, 0), Some([0, 0, 0, 255]));
    }

    #[test]
    fn y_up_maps_the_z_up_view() {
        assert_eq!(UpAxis::Y.rotated_from_z_up(DVec3::Z), DVec3::Y);
        // The front view (looking along +y in z-up) looks along −z in y-up.
        assert_eq!(UpAxis::Y.rotated_from_z_up(DVec3::Y), -DVec3::Z);
    }

    /// Two armpits crossing themselves and one knee: the section goes through the armpit with
    /// the most crossing vertices, not through the middle of the three.
    #[test]
    fn the_section_goes_through_the_densest_self_crossing() {
        let cloud = |centre: DVec3, n: usize| (0..n).map(move |k| centre + DVec3::splat(0.001 * k as f64));
        let left = DVec3::new(-1.0, 0.0, 1.5);
        let points: Vec<DVec3> = cloud(left, 30)
            .chain(cloud(DVec3::new(1.0, 0.0, 1.5), 20))
            .chain(cloud(DVec3::new(0.3, 0.0, 0.5), 10))
            .collect();
        let centre = densest_cluster(&points).unwrap();
        assert!((centre - left).length() < 0.05, "{centre}");
        assert_eq!(densest_cluster(&[]), None);
        assert_eq!(densest_cluster(&[left, left]), Some(left));
    }
}
