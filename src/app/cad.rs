//! `curve --cad MODEL`: the mesh's boundary bound to a CAD model by its
//! entity tags, no geometry file needed.
//!
//! Each boundary entity of the mesh (a curve in 2D, a surface in 3D)
//! becomes a part of its own, bound to the model's entity of the same
//! dimension and tag: curved entities are targets the new nodes go onto,
//! flat ones (Gmsh's "Plane" and "Line") slip walls the nodes glide in.
//! In 3D, two parts whose CAD surfaces share a curve meet along it
//! ([`BoundaryPart::meets`]). A geometry file may still bind physical
//! groups (`slip`, `fixed`, or another shape): its tables govern the
//! entities of those groups.
//!
//! The binding is checked before anything is computed: every entity must
//! exist in the model, and every node must lie on the model's entity it
//! is classified on (the surface of its facets; in 3D the curve a node of
//! the file's curve entities is on; the point of a point entity), within
//! the shape tolerance of its shortest edge.

use crate::app::bind::GeometryFile;
use crate::app::case::CaseError;
use crate::deform::{BoundaryPart, Correspondence, MoveMode, PartKind};
use crate::geometry::cad::CadModel;
use crate::geometry::ClosestPoint;
use crate::io::layout::Layout;
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;

/// The mesh's boundary regrouped by entity, and the parts bound to the model.
pub struct CadParts<const D: usize> {
    /// One copy of each boundary facet, its part the index of its entity.
    pub facets: Vec<(Vec<usize>, usize)>,
    /// Per entity, its part.
    pub parts: Vec<BoundaryPart<D>>,
    /// Per part, its name (`surface 7`, `curve 3`).
    pub names: Vec<String>,
}

/// What to say when the mesh and the model do not match.
const ADVICE: &str = "the mesh must be made from this model, read by the same Gmsh version with the same import options; \
     if the meshing script changed the model (healing, fragments, boolean operations), write the model it meshed in that session \
     (gmsh.write(\"model.brep\") or \".xao\") and pass that file to --cad";

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
    let err = |message: String| CaseError { file: file.clone(), message };
    let gmsh = |e: crate::geometry::cad::CadError| err(e.to_string());
    let (facets, groups) = by_entity(layout, facets, names).map_err(err)?;
    let tags: Vec<i64> = groups.keys().copied().collect();
    let kind_word = if D == 2 { "curve" } else { "surface" };
    let in_model = model.entities(D - 1).map_err(gmsh)?;
    for &t in &tags {
        if !in_model.contains(&(t as i32)) {
            return Err(err(format!("the mesh's {kind_word} {t} is not in the model (its {kind_word}s: {}): {ADVICE}", list(&in_model))));
        }
    }
    let overrides = match geometry {
        Some((g, gfile)) => Some(g.parts::<D>(names, gfile)?),
        None => None,
    };
    let mut parts = Vec::with_capacity(tags.len());
    for &t in &tags {
        let ty = model.entity_type(D - 1, t as i32).map_err(gmsh)?;
        let flat = matches!(ty.as_str(), "Plane" | "Line");
        let shape: Arc<dyn ClosestPoint<D>> = Arc::new(model.shape(D - 1, t as i32));
        let kind = match overridden(&overrides, &groups[&t], names, t).map_err(err)? {
            Some(PartKind::Slip { wall: None }) if !flat => PartKind::Slip { wall: Some(shape) },
            Some(kind) => kind,
            None if flat => PartKind::Slip { wall: None },
            None => PartKind::Move { target: shape, correspondence: Correspondence::Normal, mode: MoveMode::Sliding },
        };
        parts.push(BoundaryPart::new(format!("{kind_word} {t}"), kind));
    }
    if D == 3 {
        meetings(model, &tags, &mut parts).map_err(gmsh)?;
    }
    let names: Vec<String> = parts.iter().map(|p| p.name.clone()).collect();
    let cad = CadParts { facets, parts, names };
    check_nodes(model, &cad, &tags, (layout, nodes), tolerance).map_err(err)?;
    Ok(cad)
}

/// The tags in `v`, as a short list.
fn list(v: &[i32]) -> String {
    let shown: Vec<String> = v.iter().take(30).map(|t| t.to_string()).collect();
    if v.len() > 30 { format!("{}, … ({} in all)", shown.join(", "), v.len()) } else { shown.join(", ") }
}

/// One copy of each facet with the index of its entity (in tag order),
/// and per entity tag the parts (groups) its facets were read into.
type ByEntity = (Vec<(Vec<usize>, usize)>, BTreeMap<i64, Vec<usize>>);
fn by_entity(layout: &Layout, facets: &[(Vec<usize>, usize)], names: &[String]) -> Result<ByEntity, String> {
    let dim = layout.elements.iter().filter(|e| e.shape.dim() > 0).map(|e| e.shape.dim()).max().unwrap_or(1) - 1;
    let key = |n: &[usize]| {
        let mut k = n.to_vec();
        k.sort_unstable();
        k
    };
    let entity_of: HashMap<Vec<usize>, i64> = layout.elements.iter().filter(|e| e.shape.dim() == dim).map(|e| (key(&e.nodes), e.entity)).collect();
    let mut groups: BTreeMap<i64, Vec<usize>> = BTreeMap::new();
    let mut seen: HashMap<Vec<usize>, ()> = HashMap::new();
    let mut kept: Vec<(Vec<usize>, i64)> = Vec::new();
    for (nodes, part) in facets {
        let k = key(nodes);
        let Some(&e) = entity_of.get(&k) else {
            let tags: Vec<u64> = nodes.iter().map(|&n| layout.node_tags[n]).collect();
            return Err(format!("the mesh's boundary element on nodes {tags:?} (group `{}`) is on no entity of its file", names[*part]));
        };
        let g = groups.entry(e).or_default();
        if !g.contains(part) {
            g.push(*part);
        }
        if seen.insert(k, ()).is_none() {
            kept.push((nodes.clone(), e));
        }
    }
    let index: HashMap<i64, usize> = groups.keys().enumerate().map(|(i, &t)| (t, i)).collect();
    Ok((kept.into_iter().map(|(n, e)| (n, index[&e])).collect(), groups))
}

/// The kind the geometry file gives entity `tag`, in groups `of` (of
/// `names`), if it binds one of them; two bound groups are refused.
fn overridden<const D: usize>(overrides: &Option<(Vec<BoundaryPart<D>>, Vec<String>)>, of: &[usize], names: &[String], tag: i64) -> Result<Option<PartKind<D>>, String> {
    let Some((parts, unbound)) = overrides else { return Ok(None) };
    let bound: Vec<usize> = of.iter().copied().filter(|&g| !unbound.contains(&names[g])).collect();
    match bound.as_slice() {
        [] => Ok(None),
        [g] => Ok(Some(parts[*g].kind.clone())),
        [a, b, ..] => Err(format!("entity {tag} is in groups `{}` and `{}`, and the geometry file binds both: an element can have one behaviour only", names[*a], names[*b])),
    }
}

/// Records, for every two parts whose surfaces share CAD curves, those
/// curves ([`BoundaryPart::meets`]).
fn meetings<const D: usize>(model: &Arc<CadModel>, tags: &[i64], parts: &mut [BoundaryPart<D>]) -> Result<(), crate::geometry::cad::CadError> {
    let bounds: Vec<Vec<i32>> = tags.iter().map(|&t| model.boundary(2, t as i32)).collect::<Result<_, _>>()?;
    for a in 0..tags.len() {
        for b in 0..tags.len() {
            let shared: Vec<Arc<dyn ClosestPoint<D>>> = bounds[a].iter().filter(|c| a != b && bounds[b].contains(c)).map(|&c| Arc::new(model.shape(1, c)) as Arc<dyn ClosestPoint<D>>).collect();
            if !shared.is_empty() {
                parts[a].meets.push((b, shared));
            }
        }
    }
    Ok(())
}

/// Every node on the model's entities it lies on, within `tolerance` of
/// its shortest facet edge (see the module docs); the first miss named.
fn check_nodes<const D: usize>(model: &Arc<CadModel>, cad: &CadParts<D>, tags: &[i64], (layout, nodes): (&Layout, &[[f64; D]]), tolerance: f64) -> Result<(), String> {
    let mut shortest = vec![f64::INFINITY; nodes.len()];
    for (f, _) in &cad.facets {
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            let l = crate::numeric::dist2(nodes[a], nodes[b]).sqrt();
            shortest[a] = shortest[a].min(l);
            shortest[b] = shortest[b].min(l);
        }
    }
    let kind_word = if D == 2 { "curve" } else { "surface" };
    let miss = |n: usize, what: String, d: f64| {
        format!(
            "node {} of the mesh lies {d:.3e} from the model's {what}, more than the shape tolerance ({tolerance:.1e} of its shortest edge, {:.3e}): {ADVICE} (Gmsh {} here)",
            layout.node_tags[n],
            shortest[n],
            model.version
        )
    };
    let mut checked = vec![false; nodes.len()];
    for (f, part) in &cad.facets {
        let shape = model.shape(D - 1, tags[*part] as i32);
        for &n in f.iter().filter(|&&n| !std::mem::replace(&mut checked[n], true)) {
            let d = ClosestPoint::<D>::distance(&shape, nodes[n]);
            if !(d <= tolerance * shortest[n]) {
                return Err(miss(n, format!("{kind_word} {} (the entity of its boundary elements)", tags[*part]), d));
            }
        }
    }
    // the file's own classification of the nodes on curves and points
    let points = model.entities(0).map_err(|e| e.to_string())?;
    let curves = model.entities(1).map_err(|e| e.to_string())?;
    for (n, &(dim, tag)) in layout.node_entity.iter().enumerate().filter(|(n, _)| shortest[*n].is_finite()) {
        let x: [f64; 3] = std::array::from_fn(|k| if k < D { nodes[n][k] } else { 0.0 });
        let known = match (dim, D) {
            (0, _) => points.contains(&(tag as i32)),
            (1, 3) => curves.contains(&(tag as i32)),
            _ => continue,
        };
        if !known {
            return Err(format!("node {} of the mesh is on the file's {} {tag}, which is not in the model: {ADVICE}", layout.node_tags[n], ["point", "curve"][dim]));
        }
        let d = match dim {
            0 => crate::numeric::dist2(model.point(tag as i32).map_err(|e| e.to_string())?, x).sqrt(),
            _ => ClosestPoint::<3>::distance(&model.shape(1, tag as i32), x),
        };
        if !(d <= tolerance * shortest[n]) {
            return Err(miss(n, format!("{} {tag} (the entity the file puts it on)", ["point", "curve"][dim]), d));
        }
    }
    match model.failure() {
        Some(e) => Err(e.to_string()),
        None => Ok(()),
    }
}
