//! `curve --cad MODEL`: the mesh's boundary bound to a CAD model by
//! geometry, no geometry file needed.
//!
//! Each boundary facet of the mesh (an edge in 2D, a face in 3D) is
//! bound to the model's entity of its dimension it lies on
//! ([`crate::geometry::cad::classify`]): the mesh's entity tags are a
//! first guess, no more, so a mesh made in the session that built the
//! model (whose tags a re-import of the STEP does not keep), or by
//! another mesher, binds as well. The facets on one model entity form a
//! part: curved entities are targets the new nodes go onto, flat ones
//! (Gmsh's "Plane" and "Line") slip walls the nodes glide in. In 3D, two
//! parts whose CAD surfaces share a curve meet along it
//! ([`BoundaryPart::meets`]), and every node where they meet must lie on
//! such a curve. A geometry file may still bind physical groups (`slip`,
//! `fixed`, or another shape): its tables govern the facets of those
//! groups.
//!
//! Where some facet lies on no entity of the model within the shape
//! tolerance, the run is refused naming the mesh's entity, the node, the
//! nearest model entity and the distance; when the mesh's boundary is
//! the model scaled uniformly (a mesh in millimetres, a STEP in metres),
//! the refusal gives the factor and `--cad-scale`.

use crate::app::bind::GeometryFile;
use crate::app::case::CaseError;
use crate::deform::{BoundaryPart, Correspondence, MoveMode, PartKind};
use crate::geometry::cad::classify::{self, Boundary, ClassifyError, MeshEntity, OnModel};
use crate::geometry::cad::CadModel;
use crate::geometry::ClosestPoint;
use crate::io::layout::Layout;
use serde::Serialize;
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;

/// The mesh's boundary regrouped by the model's entities, and the parts
/// bound to them.
pub struct CadParts<const D: usize> {
    /// One copy of each boundary facet, with its part.
    pub facets: Vec<(Vec<usize>, usize)>,
    /// Per model entity (and group a geometry file binds), its part.
    pub parts: Vec<BoundaryPart<D>>,
    /// Per part, its name (`surface 7`, `curve 3`: the model's tags).
    pub names: Vec<String>,
    /// Per entity of the mesh, what it was bound to.
    pub bound: Vec<Bound>,
    /// The mesh's boundary nodes moved onto the model: each node, its
    /// place there (see [`CadParts::put_on_model`]).
    pub onto: Vec<(usize, [f64; D])>,
}

impl<const D: usize> CadParts<D> {
    /// Puts the mesh's boundary nodes exactly on the model: on its face
    /// (a curve in 2D) a node of one, on the curve two faces meet along a
    /// node where they meet, on the model's point a corner. Each moves
    /// less than its tolerance (checked in [`bind`]); why: a mesh
    /// made before the STEP was written and re-read may lie 1e-9 off it,
    /// and its curved nodes are put on the model exactly.
    pub fn put_on_model(&self, nodes: &mut [[f64; D]]) {
        for &(n, p) in &self.onto {
            nodes[n] = p;
        }
    }
}

/// How one entity of the mesh was bound (`report.json`, `cad.bound`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Bound {
    /// The mesh's entity as its file numbers it (`surface 8`), or `none`
    /// for boundary facets the file puts on no entity.
    pub mesh: String,
    /// The groups its facets are in.
    pub groups: Vec<String>,
    /// The model's entities its facets lie on, with how many facets each.
    pub model: BTreeMap<String, usize>,
    /// Whether the model's entity of its own tag holds all of it.
    pub by_tag: bool,
    /// The largest distance of its nodes from the model's entities they
    /// were bound to.
    pub max_distance: f64,
}

/// Binds the boundary `facets` (nodes, part of `names`) of a mesh with
/// nodes `nodes` and file layout `layout` to `model`; `geometry` may
/// override groups; `tolerance` is the shape tolerance (a fraction of a
/// node's shortest edge).
pub fn bind<const D: usize>(
    model: &Arc<CadModel>,
    (layout, nodes): (&Layout, &[[f64; D]]),
    (facets, names): (&[(Vec<usize>, usize)], &[String]),
    geometry: Option<(&GeometryFile, &str)>,
    tolerance: f64,
) -> Result<CadParts<D>, CaseError> {
    let file = model.file.display().to_string();
    let err = |message: String| CaseError {
        file: file.clone(),
        message,
    };
    let gmsh = |e: crate::geometry::cad::CadError| err(e.to_string());
    let kind_word = if D == 2 { "curve" } else { "surface" };
    let mesh = MeshFacets::new(layout, facets, D - 1);
    let lifted: Vec<[f64; 3]> = nodes
        .iter()
        .map(|&p| crate::geometry::cad::lift(p))
        .collect();
    let tol = tolerances(&mesh.facets, &lifted, tolerance);
    let boundary = Boundary {
        nodes: &lifted,
        tolerance: &tol,
        facets: &mesh.facets,
    };
    let on = match classify::classify(model, D - 1, boundary, &mesh.entities()) {
        Ok(on) => on,
        Err(ClassifyError::Cad(e)) => return Err(gmsh(e)),
        Err(ClassifyError::Off(off)) => {
            return Err(err(refusal(
                model,
                &mesh,
                (layout, boundary),
                (&off, tolerance),
                names,
            )))
        }
    };
    let overrides = match geometry {
        Some((g, gfile)) => Some(g.parts::<D>(names, gfile)?),
        None => None,
    };
    // a part per model entity and group the geometry file binds there
    let mut keys: BTreeMap<(i32, Option<usize>), usize> = BTreeMap::new();
    let mut key_of = Vec::with_capacity(on.len());
    for (f, o) in on.iter().enumerate() {
        let bound = overridden(&overrides, &mesh.groups[f], names).map_err(|m| {
            err(format!(
                "the mesh's {}: {m}",
                mesh.entity_name(f, kind_word)
            ))
        })?;
        keys.insert((o.tag, bound), 0);
        key_of.push((o.tag, bound));
    }
    // parts in the order of the model's tags, whatever the order of the
    // file's elements: the same mesh from another writer (meshio's MSH
    // 2.2) is curved to the same nodes
    for (i, v) in keys.values_mut().enumerate() {
        *v = i;
    }
    let part_of: Vec<usize> = key_of.iter().map(|k| keys[k]).collect();
    let mut parts: Vec<Option<BoundaryPart<D>>> = vec![None; keys.len()];
    for (&(tag, group), &i) in &keys {
        let ty = model.entity_type(D - 1, tag).map_err(gmsh)?;
        let flat = matches!(ty.as_str(), "Plane" | "Line");
        let shape: Arc<dyn ClosestPoint<D>> = Arc::new(model.shape(D - 1, tag));
        let given = group.and_then(|g| overrides.as_ref().map(|o| o.0[g].kind.clone()));
        let kind = match given {
            Some(PartKind::Slip { wall: None }) if !flat => PartKind::Slip { wall: Some(shape) },
            Some(kind) => kind,
            None if flat => PartKind::Slip { wall: None },
            None => PartKind::Move {
                target: shape,
                correspondence: Correspondence::Normal,
                mode: MoveMode::Sliding,
            },
        };
        let name = match group {
            Some(g) => format!("{kind_word} {tag} (group `{}`)", names[g]),
            None => format!("{kind_word} {tag}"),
        };
        parts[i] = Some(BoundaryPart::new(name, kind));
    }
    let mut parts: Vec<BoundaryPart<D>> = parts
        .into_iter()
        .map(|p| p.expect("every key has a part"))
        .collect();
    let tags: Vec<i32> = {
        let mut t = vec![0; keys.len()];
        for (&(tag, _), &i) in &keys {
            t[i] = tag;
        }
        t
    };
    let at = where_faces_meet(&mesh, &part_of, &tags);
    let mut onto = on_faces(model, &mesh, (&part_of, &tags), &at, boundary);
    if D == 3 {
        let along = meetings(model, &tags, &at, &mut parts).map_err(gmsh)?;
        onto.extend(check_meetings(model, &at, (layout, boundary), &along).map_err(err)?);
    } else {
        onto.extend(at_corners(model, &at, boundary).map_err(gmsh)?);
    }
    let onto = onto
        .into_iter()
        .map(|(n, p)| (n, std::array::from_fn(|k| p[k])))
        .collect();
    if let Some(e) = model.failure() {
        return Err(gmsh(e));
    }
    let bound = mesh.bound(&on, names, kind_word);
    let names: Vec<String> = parts.iter().map(|p| p.name.clone()).collect();
    let mut facets: Vec<(Vec<usize>, usize)> = mesh.facets.into_iter().zip(part_of).collect();
    facets.sort_by_cached_key(|(f, part)| {
        let mut k = f.clone();
        k.sort_unstable();
        (*part, k)
    });
    Ok(CadParts {
        facets,
        parts,
        names,
        bound,
        onto,
    })
}

/// Per node, how far it may lie from its entity: `tolerance` times its
/// shortest facet edge (0 for nodes on no facet).
fn tolerances(facets: &[Vec<usize>], nodes: &[[f64; 3]], tolerance: f64) -> Vec<f64> {
    let mut shortest = vec![f64::INFINITY; nodes.len()];
    for f in facets {
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            let l = crate::numeric::dist2(nodes[a], nodes[b]).sqrt();
            shortest[a] = shortest[a].min(l);
            shortest[b] = shortest[b].min(l);
        }
    }
    shortest
        .into_iter()
        .map(|l| if l.is_finite() { tolerance * l } else { 0.0 })
        .collect()
}

/// The mesh's boundary facets, each once, with the groups each is in and
/// the file's entity it is on.
struct MeshFacets {
    facets: Vec<Vec<usize>>,
    groups: Vec<Vec<usize>>,
    entity: Vec<Option<i64>>,
}

impl MeshFacets {
    fn new(layout: &Layout, facets: &[(Vec<usize>, usize)], dim: usize) -> MeshFacets {
        let key = |n: &[usize]| {
            let mut k = n.to_vec();
            k.sort_unstable();
            k
        };
        let entity_of: HashMap<Vec<usize>, i64> = layout
            .elements
            .iter()
            .filter(|e| e.shape.dim() == dim)
            .map(|e| (key(&e.nodes), e.entity))
            .collect();
        let mut index: HashMap<Vec<usize>, usize> = HashMap::new();
        let mut m = MeshFacets {
            facets: Vec::new(),
            groups: Vec::new(),
            entity: Vec::new(),
        };
        for (nodes, part) in facets {
            let k = key(nodes);
            let i = *index.entry(k.clone()).or_insert_with(|| {
                m.facets.push(nodes.clone());
                m.groups.push(Vec::new());
                m.entity.push(entity_of.get(&k).copied());
                m.facets.len() - 1
            });
            if !m.groups[i].contains(part) {
                m.groups[i].push(*part);
            }
        }
        m
    }

    /// The facets grouped by the file's entities (those on none last).
    fn entities(&self) -> Vec<MeshEntity> {
        let mut by: BTreeMap<Option<i64>, Vec<usize>> = BTreeMap::new();
        for (f, e) in self.entity.iter().enumerate() {
            by.entry(*e).or_default().push(f);
        }
        by.into_iter()
            .map(|(e, facets)| MeshEntity {
                facets,
                guess: e.and_then(|t| i32::try_from(t).ok()),
            })
            .collect()
    }

    fn entity_name(&self, f: usize, kind_word: &str) -> String {
        match self.entity[f] {
            Some(t) => format!("{kind_word} {t}"),
            None => format!("boundary elements on no {kind_word} of the file"),
        }
    }

    /// Per entity of the mesh, what its facets were bound to.
    fn bound(&self, on: &[OnModel], names: &[String], kind_word: &str) -> Vec<Bound> {
        self.entities()
            .into_iter()
            .map(|e| {
                let mut model: BTreeMap<String, usize> = BTreeMap::new();
                let mut groups: Vec<String> = Vec::new();
                for &f in &e.facets {
                    *model
                        .entry(format!("{kind_word} {}", on[f].tag))
                        .or_default() += 1;
                    for &g in &self.groups[f] {
                        if !groups.contains(&names[g]) {
                            groups.push(names[g].clone());
                        }
                    }
                }
                let by_tag = e
                    .guess
                    .is_some_and(|t| e.facets.iter().all(|&f| on[f].tag == t));
                let max_distance = e.facets.iter().map(|&f| on[f].distance).fold(0.0, f64::max);
                let mesh = match self.entity[e.facets[0]] {
                    Some(t) => format!("{kind_word} {t}"),
                    None => "none".into(),
                };
                Bound {
                    mesh,
                    groups,
                    model,
                    by_tag,
                    max_distance,
                }
            })
            .collect()
    }
}

/// The message for a facet on no entity of the model: the unit mistake
/// when the boxes say so, else the mesh's entity, the node, the nearest
/// model entity and the distance.
fn refusal(
    model: &CadModel,
    mesh: &MeshFacets,
    (layout, b): (&Layout, Boundary),
    (off, tolerance): (&classify::Off, f64),
    names: &[String],
) -> String {
    let dim = b
        .facets
        .first()
        .map_or(1, |f| if f.len() == 2 { 1 } else { 2 });
    let kind_word = ["point", "curve", "surface"][dim];
    let ours = classify::bounds(b.facets.iter().flatten().map(|&n| b.nodes[n]));
    if let Ok(theirs) = model.bounding_box(-1, -1) {
        if let Some(s) = classify::scale_between(ours, theirs) {
            let box_text = |x: [[f64; 3]; 2]| {
                format!(
                    "({:.4e}, {:.4e}, {:.4e}) to ({:.4e}, {:.4e}, {:.4e})",
                    x[0][0], x[0][1], x[0][2], x[1][0], x[1][1], x[1][2]
                )
            };
            let (factor, units) = match classify::unit_factor(s) {
                Some((f, a, m)) => (
                    format!("{f}"),
                    format!(": the mesh is likely in {a} and the model in {m}"),
                ),
                None => (format!("{s:.4}"), String::new()),
            };
            return format!(
                "the mesh's boundary is the model scaled by {factor} (its bounding box {} against the model's {}){units}. Give --cad-scale {factor} to read the model in the mesh's units",
                box_text(ours),
                box_text(theirs)
            );
        }
    }
    let groups: Vec<&str> = mesh.groups[off.facet]
        .iter()
        .map(|&g| names[g].as_str())
        .collect();
    let nearest = match off.nearest {
        Some(t) => format!("the nearest of the model's {kind_word}s ({kind_word} {t})"),
        None => format!("every {kind_word} of the model (Gmsh could not project it)"),
    };
    let p = b.nodes[off.node];
    format!(
        "the mesh's {} (group{} `{}`) is on no entity of the model: its node {} at ({:.6}, {:.6}, {:.6}) lies {:.3e} from {nearest}, more than the shape tolerance ({tolerance:.1e} of its shortest edge: {:.3e}). Is the mesh made from this model, in its units? (Gmsh {} here)",
        mesh.entity_name(off.facet, kind_word),
        if groups.len() == 1 { "" } else { "s" },
        groups.join("`, `"),
        layout.node_tags[off.node],
        p[0],
        p[1],
        p[2],
        off.distance,
        off.tolerance,
        model.version
    )
}

/// The group of `of` (of `names`) the geometry file binds, if any; two
/// bound groups are refused.
fn overridden<const D: usize>(
    overrides: &Option<(Vec<BoundaryPart<D>>, Vec<String>)>,
    of: &[usize],
    names: &[String],
) -> Result<Option<usize>, String> {
    let Some((_, unbound)) = overrides else {
        return Ok(None);
    };
    let bound: Vec<usize> = of
        .iter()
        .copied()
        .filter(|&g| !unbound.contains(&names[g]))
        .collect();
    match bound.as_slice() {
        [] => Ok(None),
        [g] => Ok(Some(*g)),
        [a, b, ..] => Err(format!("an element is in groups `{}` and `{}`, and the geometry file binds both: an element can have one behaviour only", names[*a], names[*b])),
    }
}

/// The model's curves bounding each surface in `tags`.
type Curves = HashMap<i32, Vec<i32>>;

/// Per node on facets of two or more of the model's surfaces, those
/// surfaces (model tags); the facets' model tags are `tags[part_of[f]]`.
fn where_faces_meet(mesh: &MeshFacets, part_of: &[usize], tags: &[i32]) -> Vec<(usize, Vec<i32>)> {
    let mut faces: HashMap<usize, Vec<i32>> = HashMap::new();
    for (f, nodes) in mesh.facets.iter().enumerate() {
        let t = tags[part_of[f]];
        for &n in nodes {
            let v = faces.entry(n).or_default();
            if !v.contains(&t) {
                v.push(t);
            }
        }
    }
    let mut at: Vec<(usize, Vec<i32>)> = faces.into_iter().filter(|(_, v)| v.len() > 1).collect();
    at.sort_unstable();
    at
}

/// The feet on their model entity of the nodes on one only (not in
/// `at`), where the foot is within the node's tolerance.
fn on_faces(
    model: &Arc<CadModel>,
    mesh: &MeshFacets,
    (part_of, tags): (&[usize], &[i32]),
    at: &[(usize, Vec<i32>)],
    b: Boundary,
) -> Vec<(usize, [f64; 3])> {
    let dim = if mesh.facets.first().is_some_and(|f| f.len() == 2) {
        1
    } else {
        2
    };
    let several: std::collections::HashSet<usize> = at.iter().map(|a| a.0).collect();
    let mut seen = vec![false; b.nodes.len()];
    let mut shapes: HashMap<i32, crate::geometry::cad::CadShape> = HashMap::new();
    let mut out = Vec::new();
    for (f, nodes) in mesh.facets.iter().enumerate() {
        let t = tags[part_of[f]];
        for &n in nodes {
            if several.contains(&n) || std::mem::replace(&mut seen[n], true) {
                continue;
            }
            let shape = shapes.entry(t).or_insert_with(|| model.shape(dim, t));
            let q = ClosestPoint::<3>::closest_point(shape, b.nodes[n]);
            if crate::numeric::dist2(q, b.nodes[n]).sqrt() <= b.tolerance[n] {
                out.push((n, q));
            }
        }
    }
    out
}

/// In 2D, the model's point two curves share, for a node on both
/// (within its tolerance).
fn at_corners(
    model: &CadModel,
    at: &[(usize, Vec<i32>)],
    b: Boundary,
) -> Result<Vec<(usize, [f64; 3])>, crate::geometry::cad::CadError> {
    let mut out = Vec::new();
    for (n, on) in at {
        let mut ends: Vec<i32> = Vec::new();
        for &c in on {
            ends.extend(model.boundary(1, c)?);
        }
        let mut best: Option<(f64, [f64; 3])> = None;
        for &e in &ends {
            let q = model.point(e)?;
            let d = crate::numeric::dist2(q, b.nodes[*n]).sqrt();
            if d <= b.tolerance[*n] && best.is_none_or(|(m, _)| d < m) {
                best = Some((d, q));
            }
        }
        if let Some((_, q)) = best {
            out.push((*n, q));
        }
    }
    Ok(out)
}

/// Records, for every two parts whose surfaces (model tags `tags`) meet
/// in the mesh (`at`), the model's curves they meet along
/// ([`BoundaryPart::meets`]); returns those curves per pair of surfaces.
fn meetings<const D: usize>(
    model: &Arc<CadModel>,
    tags: &[i32],
    at: &[(usize, Vec<i32>)],
    parts: &mut [BoundaryPart<D>],
) -> Result<HashMap<(i32, i32), Vec<i32>>, crate::geometry::cad::CadError> {
    let mut pairs: Vec<(i32, i32)> = at
        .iter()
        .flat_map(|(_, on)| {
            on.iter()
                .flat_map(move |&a| on.iter().filter(move |&&b| a < b).map(move |&b| (a, b)))
        })
        .collect();
    pairs.sort_unstable();
    pairs.dedup();
    let mut curves: Curves = HashMap::new();
    for &t in pairs.iter().flat_map(|(a, b)| [a, b]) {
        if let std::collections::hash_map::Entry::Vacant(v) = curves.entry(t) {
            v.insert(model.boundary(2, t)?);
        }
    }
    let mut along: HashMap<(i32, i32), Vec<i32>> = HashMap::new();
    for &(a, b) in &pairs {
        let mut shared: Vec<i32> = curves[&a]
            .iter()
            .copied()
            .filter(|c| curves[&b].contains(c))
            .collect();
        if shared.is_empty() {
            // faces of solids not glued (a STEP of touching blocks) each
            // have their own copy of the curve they meet along
            for (x, y) in [(a, b), (b, a)] {
                for &c in &curves[&x] {
                    if lies_on(model, c, y)? {
                        shared.push(c);
                    }
                }
            }
        }
        along.insert((a, b), shared);
    }
    for i in 0..tags.len() {
        for j in 0..tags.len() {
            let key = (tags[i].min(tags[j]), tags[i].max(tags[j]));
            if let Some(c) = along
                .get(&key)
                .filter(|c| tags[i] != tags[j] && !c.is_empty())
            {
                parts[i].meets.push((
                    j,
                    c.iter()
                        .map(|&c| Arc::new(model.shape(1, c)) as Arc<dyn ClosestPoint<D>>)
                        .collect(),
                ));
            }
        }
    }
    Ok(along)
}

/// Whether curve `c` lies on surface `s`: 9 points of it within 1e-9 of
/// its length (a copy of one of `s`'s curves does, to round-off).
fn lies_on(model: &CadModel, c: i32, s: i32) -> Result<bool, crate::geometry::cad::CadError> {
    let pts = model.curve_points(c, 9)?;
    let size = classify::bounds(pts.iter().copied());
    let tol = 1e-9
        * crate::numeric::dist2(size[0], size[1])
            .sqrt()
            .max(f64::MIN_POSITIVE);
    let feet = model.closest_points(2, s, &pts)?;
    Ok(feet.len() == pts.len()
        && pts
            .iter()
            .zip(&feet)
            .all(|(p, q)| crate::numeric::dist2(*p, *q).sqrt() <= tol)
        && model.count_inside(2, s, &feet)? == pts.len())
}

/// Every node where facets on two of the model's surfaces meet lies on a
/// curve the two share, within its tolerance: there the new nodes go onto
/// that curve. The first that does not is named.
fn check_meetings(
    model: &Arc<CadModel>,
    at: &[(usize, Vec<i32>)],
    (layout, b): (&Layout, Boundary),
    along: &HashMap<(i32, i32), Vec<i32>>,
) -> Result<Vec<(usize, [f64; 3])>, String> {
    let mut onto = Vec::new();
    for (n, on) in at {
        let n = *n;
        let shared: Vec<i32> = on
            .iter()
            .flat_map(|&a| on.iter().filter(move |&&x| a < x).map(move |&x| (a, x)))
            .flat_map(|k| along.get(&k).cloned().unwrap_or_default())
            .collect();
        let mut best: Option<(f64, [f64; 3], i32)> = None;
        for &c in &shared {
            let shape = model.shape(1, c);
            let q = ClosestPoint::<3>::closest_point(&shape, b.nodes[n]);
            let d = crate::numeric::dist2(q, b.nodes[n]).sqrt();
            if best.is_none_or(|(m, _, _)| d < m) {
                best = Some((d, q, c));
            }
        }
        match best {
            Some((d, q, c)) if d <= b.tolerance[n] => {
                // a corner (three faces or more): the curve's end point,
                // if the node is at it
                let corner = if on.len() > 2 {
                    let ends = model.boundary(1, c).map_err(|e| e.to_string())?;
                    ends.iter()
                        .filter_map(|&e| model.point(e).ok())
                        .find(|p| crate::numeric::dist2(*p, b.nodes[n]).sqrt() <= b.tolerance[n])
                } else {
                    None
                };
                onto.push((n, corner.unwrap_or(q)));
            }
            _ => {
                let list: Vec<String> = on.iter().map(|t| format!("surface {t}")).collect();
                let why = match best {
                    None => "which share no curve in the model".to_string(),
                    Some((d, _, _)) => format!("but it lies {d:.3e} from the curves they share, more than its tolerance {:.3e}", b.tolerance[n]),
                };
                return Err(format!(
                    "node {} of the mesh is where its facets on the model's {} meet, {why}",
                    layout.node_tags[n],
                    list.join(" and ")
                ));
            }
        }
    }
    Ok(onto)
}
