//! The live Gmsh model of a process that initialised Gmsh itself (the
//! Python `gmsh` module): its mesh read as an MSH 4.1 text in memory, its
//! CAD as a [`CadModel`], and the curved mesh written back into it.
//!
//! Why through the MSH text: the reader then checks the live mesh exactly
//! as it checks a file (the same refusals, naming the model's own element
//! and node tags), and the curve job runs unchanged. Writing back, Gmsh's
//! own `setOrder` makes the high-order elements (its node numbering, its
//! classification of every new node on its entity, its periodic links)
//! and each node is then moved to the curved mesh's place.

use std::ffi::{c_char, c_int, CString};
use std::fmt::Write as _;
use std::path::Path;
use std::sync::{Arc, Mutex};

use super::gmsh::{self, symbol, Session};
use super::{CadError, CadModel};
use crate::io::layout::Layout;
use crate::io::msh::{gmsh_perm, msh_type, shape_of};

type ErrPtr = *mut c_int;

/// Elements of one type: the type, the element tags and their nodes'
/// tags (Gmsh's local order).
type Block = (i32, Vec<usize>, Vec<usize>);

/// Element tags and their nodes' tags.
type Tagged = (Vec<usize>, Vec<usize>);

/// The mesh calls of Gmsh's C API (`gmshc.h`, 4.11 and later).
struct MeshApi {
    get_current: unsafe extern "C" fn(*mut *mut c_char, ErrPtr),
    get_dimension: unsafe extern "C" fn(ErrPtr) -> c_int,
    option_get_number: unsafe extern "C" fn(*const c_char, *mut f64, ErrPtr),
    get_physical_groups: unsafe extern "C" fn(*mut *mut c_int, *mut usize, c_int, ErrPtr),
    get_physical_name: unsafe extern "C" fn(c_int, c_int, *mut *mut c_char, ErrPtr),
    groups_for_entity: unsafe extern "C" fn(c_int, c_int, *mut *mut c_int, *mut usize, ErrPtr),
    get_nodes: unsafe extern "C" fn(*mut *mut usize, *mut usize, *mut *mut f64, *mut usize, *mut *mut f64, *mut usize, c_int, c_int, c_int, c_int, ErrPtr),
    #[allow(clippy::type_complexity)]
    get_elements: unsafe extern "C" fn(*mut *mut c_int, *mut usize, *mut *mut *mut usize, *mut *mut usize, *mut usize, *mut *mut *mut usize, *mut *mut usize, *mut usize, c_int, c_int, ErrPtr),
    get_periodic: unsafe extern "C" fn(c_int, *const c_int, usize, *mut *mut c_int, *mut usize, ErrPtr),
    get_periodic_nodes: unsafe extern "C" fn(c_int, c_int, *mut c_int, *mut *mut usize, *mut usize, *mut *mut usize, *mut usize, *mut *mut f64, *mut usize, c_int, ErrPtr),
    set_order: unsafe extern "C" fn(c_int, ErrPtr),
    set_node: unsafe extern "C" fn(usize, *const f64, usize, *const f64, usize, ErrPtr),
    add_nodes: unsafe extern "C" fn(c_int, c_int, *const usize, usize, *const f64, usize, *const f64, usize, ErrPtr),
    remove_elements: unsafe extern "C" fn(c_int, c_int, *const usize, usize, ErrPtr),
    add_elements_by_type: unsafe extern "C" fn(c_int, c_int, *const usize, usize, *const usize, usize, ErrPtr),
}

impl MeshApi {
    fn load(s: &Session) -> Result<MeshApi, CadError> {
        let (lib, path) = (s.library(), s.path.as_path());
        // SAFETY: the types are those of gmshc.h (4.11 and later)
        unsafe {
            Ok(MeshApi {
                get_current: symbol(lib, path, "gmshModelGetCurrent")?,
                get_dimension: symbol(lib, path, "gmshModelGetDimension")?,
                option_get_number: symbol(lib, path, "gmshOptionGetNumber")?,
                get_physical_groups: symbol(lib, path, "gmshModelGetPhysicalGroups")?,
                get_physical_name: symbol(lib, path, "gmshModelGetPhysicalName")?,
                groups_for_entity: symbol(lib, path, "gmshModelGetPhysicalGroupsForEntity")?,
                get_nodes: symbol(lib, path, "gmshModelMeshGetNodes")?,
                get_elements: symbol(lib, path, "gmshModelMeshGetElements")?,
                get_periodic: symbol(lib, path, "gmshModelMeshGetPeriodic")?,
                get_periodic_nodes: symbol(lib, path, "gmshModelMeshGetPeriodicNodes")?,
                set_order: symbol(lib, path, "gmshModelMeshSetOrder")?,
                set_node: symbol(lib, path, "gmshModelMeshSetNode")?,
                add_nodes: symbol(lib, path, "gmshModelMeshAddNodes")?,
                remove_elements: symbol(lib, path, "gmshModelMeshRemoveElements")?,
                add_elements_by_type: symbol(lib, path, "gmshModelMeshAddElementsByType")?,
            })
        }
    }
}

/// The session attached to the process's Gmsh and its mesh calls.
struct Live<'a> {
    s: &'a mut Session,
    api: MeshApi,
}

impl Live<'_> {
    fn current_name(&self) -> Result<String, CadError> {
        let (mut p, mut ierr) = (std::ptr::null_mut(), 0);
        unsafe { (self.api.get_current)(&mut p, &mut ierr) };
        self.s.check(ierr, "gmshModelGetCurrent")?;
        Ok(if p.is_null() { String::new() } else { self.s.take_string(p) })
    }

    fn dimension(&self) -> Result<usize, CadError> {
        let mut ierr = 0;
        let d = unsafe { (self.api.get_dimension)(&mut ierr) };
        self.s.check(ierr, "gmshModelGetDimension")?;
        Ok(d.max(0) as usize)
    }

    fn option(&self, name: &str) -> Result<f64, CadError> {
        let c = CString::new(name).expect("option names have no NUL");
        let (mut v, mut ierr) = (0.0, 0);
        unsafe { (self.api.option_get_number)(c.as_ptr(), &mut v, &mut ierr) };
        self.s.check(ierr, name).map(|()| v)
    }

    /// `(dim, tag, name)` of every physical group (name empty if none).
    fn physical_groups(&self) -> Result<Vec<(i32, i32, String)>, CadError> {
        let (mut p, mut n, mut ierr) = (std::ptr::null_mut(), 0usize, 0);
        unsafe { (self.api.get_physical_groups)(&mut p, &mut n, -1, &mut ierr) };
        self.s.check(ierr, "gmshModelGetPhysicalGroups")?;
        let pairs = self.s.take(p, n);
        let mut out = Vec::new();
        for c in pairs.chunks_exact(2) {
            let (mut name, mut ierr) = (std::ptr::null_mut(), 0);
            unsafe { (self.api.get_physical_name)(c[0], c[1], &mut name, &mut ierr) };
            self.s.check(ierr, "gmshModelGetPhysicalName")?;
            out.push((c[0], c[1], if name.is_null() { String::new() } else { self.s.take_string(name) }));
        }
        Ok(out)
    }

    fn groups_of(&self, dim: i32, tag: i32) -> Result<Vec<i32>, CadError> {
        let (mut p, mut n, mut ierr) = (std::ptr::null_mut(), 0usize, 0);
        unsafe { (self.api.groups_for_entity)(dim, tag, &mut p, &mut n, &mut ierr) };
        self.s.check(ierr, "gmshModelGetPhysicalGroupsForEntity")?;
        Ok(self.s.take(p, n))
    }

    /// The tags and coordinates of the nodes classified on (dim, tag).
    fn nodes(&self, dim: i32, tag: i32) -> Result<(Vec<usize>, Vec<f64>), CadError> {
        let (mut t, mut nt, mut x, mut nx, mut u, mut nu, mut ierr) = (std::ptr::null_mut(), 0usize, std::ptr::null_mut(), 0usize, std::ptr::null_mut(), 0usize, 0);
        unsafe { (self.api.get_nodes)(&mut t, &mut nt, &mut x, &mut nx, &mut u, &mut nu, dim, tag, 0, 0, &mut ierr) };
        self.s.check(ierr, "gmshModelMeshGetNodes")?;
        let _ = self.s.take(u, nu);
        Ok((self.s.take(t, nt), self.s.take(x, nx)))
    }

    /// Per element type on (dim, tag): the type, the element tags and
    /// their nodes' tags.
    fn elements(&self, dim: i32, tag: i32) -> Result<Vec<Block>, CadError> {
        let (mut types, mut ntypes) = (std::ptr::null_mut(), 0usize);
        let (mut et, mut et_n, mut et_nn) = (std::ptr::null_mut(), std::ptr::null_mut(), 0usize);
        let (mut nt, mut nt_n, mut nt_nn) = (std::ptr::null_mut(), std::ptr::null_mut(), 0usize);
        let mut ierr = 0;
        unsafe { (self.api.get_elements)(&mut types, &mut ntypes, &mut et, &mut et_n, &mut et_nn, &mut nt, &mut nt_n, &mut nt_nn, dim, tag, &mut ierr) };
        self.s.check(ierr, "gmshModelMeshGetElements")?;
        let types = self.s.take(types, ntypes);
        let (et_len, nt_len) = (self.s.take(et_n, et_nn), self.s.take(nt_n, nt_nn));
        let (et, nt) = (self.s.take(et, et_nn), self.s.take(nt, nt_nn));
        Ok(types.iter().enumerate().map(|(i, &t)| (t, self.s.take(et[i], et_len[i]), self.s.take(nt[i], nt_len[i]))).collect())
    }

    /// The master of each entity of `dim` that has one, with the affine
    /// map and the (slave, master) node tags.
    #[allow(clippy::type_complexity)]
    fn periodic(&self, dim: i32, tags: &[i32]) -> Result<Vec<(i32, i32, Vec<f64>, Vec<(usize, usize)>)>, CadError> {
        let (mut m, mut nm, mut ierr) = (std::ptr::null_mut(), 0usize, 0);
        unsafe { (self.api.get_periodic)(dim, tags.as_ptr(), tags.len(), &mut m, &mut nm, &mut ierr) };
        self.s.check(ierr, "gmshModelMeshGetPeriodic")?;
        let masters = self.s.take(m, nm);
        let mut out = Vec::new();
        for (&slave, &master) in tags.iter().zip(&masters) {
            if master == slave {
                continue;
            }
            let mut tm = 0;
            let (mut a, mut na, mut b, mut nb, mut f, mut nf) = (std::ptr::null_mut(), 0usize, std::ptr::null_mut(), 0usize, std::ptr::null_mut(), 0usize);
            unsafe { (self.api.get_periodic_nodes)(dim, slave, &mut tm, &mut a, &mut na, &mut b, &mut nb, &mut f, &mut nf, 0, &mut ierr) };
            self.s.check(ierr, "gmshModelMeshGetPeriodicNodes")?;
            let (a, b, f) = (self.s.take(a, na), self.s.take(b, nb), self.s.take(f, nf));
            out.push((slave, tm, f, a.into_iter().zip(b).collect()));
        }
        Ok(out)
    }

    fn set_order(&self, order: usize) -> Result<(), CadError> {
        let mut ierr = 0;
        unsafe { (self.api.set_order)(order as c_int, &mut ierr) };
        self.s.check(ierr, "gmshModelMeshSetOrder")
    }

    fn set_node(&self, tag: usize, xyz: &[f64; 3], uv: &[f64]) -> Result<(), CadError> {
        let mut ierr = 0;
        unsafe { (self.api.set_node)(tag, xyz.as_ptr(), 3, uv.as_ptr(), uv.len(), &mut ierr) };
        self.s.check(ierr, "gmshModelMeshSetNode")
    }

    fn add_nodes(&self, (dim, tag): (i32, i32), tags: &[usize], xyz: &[f64], uv: &[f64]) -> Result<(), CadError> {
        let mut ierr = 0;
        unsafe { (self.api.add_nodes)(dim, tag, tags.as_ptr(), tags.len(), xyz.as_ptr(), xyz.len(), uv.as_ptr(), uv.len(), &mut ierr) };
        self.s.check(ierr, "gmshModelMeshAddNodes")
    }

    /// Removes every element of entity (dim, tag) (its nodes stay).
    fn clear_elements(&self, (dim, tag): (i32, i32)) -> Result<(), CadError> {
        let mut ierr = 0;
        unsafe { (self.api.remove_elements)(dim, tag, std::ptr::null(), 0, &mut ierr) };
        self.s.check(ierr, "gmshModelMeshRemoveElements")
    }

    /// Adds elements of type `t`, tags `tags` and `nodes`, to the entity
    /// `tag` of the type's dimension.
    fn add_elements(&self, tag: i32, t: i64, tags: &[usize], nodes: &[usize]) -> Result<(), CadError> {
        let mut ierr = 0;
        unsafe { (self.api.add_elements_by_type)(tag, t as c_int, tags.as_ptr(), tags.len(), nodes.as_ptr(), nodes.len(), &mut ierr) };
        self.s.check(ierr, "gmshModelMeshAddElementsByType")
    }
}

/// Runs `f` on the process's Gmsh (loaded from `library`, initialised by
/// its owner) and its current model.
fn with_live<R>(library: &Path, f: impl FnOnce(&mut Live) -> Result<R, CadError>) -> Result<R, CadError> {
    let mut guard = gmsh::attach(library)?;
    let s = guard.as_mut().expect("attached");
    let api = MeshApi::load(s)?;
    f(&mut Live { s, api })
}

/// Makes the process's Gmsh, loaded from `library` and initialised by its
/// owner, the one the CAD models of this process are read with (not
/// initialised again, no option changed).
pub fn attach(library: &Path) -> Result<(), CadError> {
    gmsh::attach(library).map(drop)
}

impl CadModel {
    /// The current model of the process's Gmsh, loaded from `library` and
    /// initialised by its owner (the Python `gmsh` module): the CAD of the
    /// mesh it holds.
    pub fn live(library: &Path) -> Result<Arc<CadModel>, CadError> {
        with_live(library, |l| {
            let name = l.current_name()?;
            Ok(Arc::new(CadModel {
                name: CString::new(name.clone()).unwrap_or_default(),
                file: format!("the Gmsh model `{name}`").into(),
                library: l.s.path.clone(),
                version: l.s.version.clone(),
                scale: 1.0,
                failure: Mutex::new(None),
                live: true,
            }))
        })
    }
}

/// The mesh of the live model (every element of every entity, as Gmsh
/// writes with `Mesh.SaveAll`), as an MSH 4.1 ASCII text, and the model's
/// name. Coordinates are written in Rust's shortest form that reads back
/// to the same double.
pub fn live_msh(library: &Path) -> Result<(String, String), CadError> {
    with_live(library, |l| {
        let name = l.current_name()?;
        let dim = l.dimension()?;
        let mut text = String::from("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n");
        let groups = l.physical_groups()?;
        let named: Vec<_> = groups.iter().filter(|g| !g.2.is_empty()).collect();
        let _ = writeln!(text, "$PhysicalNames\n{}", named.len());
        for (d, t, n) in &named {
            let _ = writeln!(text, "{d} {t} \"{}\"", n.replace('"', "'"));
        }
        text += "$EndPhysicalNames\n";
        let entities: Vec<Vec<i32>> = (0..=3).map(|d| l.s.entities(d).map(|e| e.into_iter().map(|x| x.1).collect())).collect::<Result<_, _>>()?;
        entities_section(l, &entities, &mut text)?;
        nodes_section(l, &entities, &mut text)?;
        elements_section(l, &entities, dim, &mut text)?;
        periodic_section(l, &entities, &mut text)?;
        Ok((name, text))
    })
}

fn entities_section(l: &Live, entities: &[Vec<i32>], text: &mut String) -> Result<(), CadError> {
    let _ = writeln!(text, "$Entities\n{} {} {} {}", entities[0].len(), entities[1].len(), entities[2].len(), entities[3].len());
    for (d, tags) in entities.iter().enumerate() {
        for &t in tags {
            let [lo, hi] = l.s.bounding_box(d as i32, t)?;
            let groups = l.groups_of(d as i32, t)?;
            let _ = write!(text, "{t} {} {} {}", lo[0], lo[1], lo[2]);
            if d > 0 {
                let _ = write!(text, " {} {} {}", hi[0], hi[1], hi[2]);
            }
            let _ = write!(text, " {}", groups.len());
            groups.iter().for_each(|g| {
                let _ = write!(text, " {g}");
            });
            if d > 0 {
                let bounding = l.s.boundary(d as i32, t)?;
                let _ = write!(text, " {}", bounding.len());
                bounding.iter().for_each(|b| {
                    let _ = write!(text, " {b}");
                });
            }
            text.push('\n');
        }
    }
    text.push_str("$EndEntities\n");
    Ok(())
}

/// The first line of `$Nodes` and `$Elements`: the blocks, the items and
/// the least and largest tag of the items (`tags`, one slice per block).
fn section_counts<'a>(blocks: usize, tags: impl Iterator<Item = &'a [usize]> + Clone) -> String {
    let count: usize = tags.clone().map(<[usize]>::len).sum();
    let (lo, hi) = tags.flatten().fold((usize::MAX, 0), |(lo, hi), &t| (lo.min(t), hi.max(t)));
    format!("{blocks} {count} {} {hi}", lo.min(hi))
}

fn nodes_section(l: &Live, entities: &[Vec<i32>], text: &mut String) -> Result<(), CadError> {
    let mut blocks = Vec::new();
    for (d, tags) in entities.iter().enumerate() {
        for &t in tags {
            let (n, x) = l.nodes(d as i32, t)?;
            if !n.is_empty() {
                blocks.push((d, t, n, x));
            }
        }
    }
    let _ = writeln!(text, "$Nodes\n{}", section_counts(blocks.len(), blocks.iter().map(|b| b.2.as_slice())));
    for (d, t, n, x) in &blocks {
        let _ = writeln!(text, "{d} {t} 0 {}", n.len());
        n.iter().for_each(|tag| {
            let _ = writeln!(text, "{tag}");
        });
        x.chunks_exact(3).for_each(|p| {
            let _ = writeln!(text, "{:?} {:?} {:?}", p[0], p[1], p[2]);
        });
    }
    text.push_str("$EndNodes\n");
    Ok(())
}

fn elements_section(l: &Live, entities: &[Vec<i32>], dim: usize, text: &mut String) -> Result<(), CadError> {
    let mut blocks = Vec::new();
    for (d, tags) in entities.iter().enumerate().take(dim + 1) {
        for &t in tags {
            for (ty, e, n) in l.elements(d as i32, t)? {
                // a high-order mesh is refused here, in the model's words
                if let Some((shape, p)) = shape_of(ty as i64).filter(|sp| sp.1 > 1) {
                    return Err(CadError::Gmsh {
                        call: "deformesh.gmsh.curve".into(),
                        message: format!(
                            "the model's mesh has {shape:?} elements of order {p} (element {}): it takes a linear mesh: gmsh.model.mesh.setOrder(1) first",
                            e.first().copied().unwrap_or(0)
                        ),
                    });
                }
                blocks.push((d, t, ty, e, n));
            }
        }
    }
    let _ = writeln!(text, "$Elements\n{}", section_counts(blocks.len(), blocks.iter().map(|b| b.3.as_slice())));
    for (d, t, ty, e, n) in &blocks {
        let _ = writeln!(text, "{d} {t} {ty} {}", e.len());
        let per = n.len() / e.len().max(1);
        for (k, tag) in e.iter().enumerate() {
            let _ = write!(text, "{tag}");
            n[k * per..(k + 1) * per].iter().for_each(|v| {
                let _ = write!(text, " {v}");
            });
            text.push('\n');
        }
    }
    text.push_str("$EndElements\n");
    Ok(())
}

fn periodic_section(l: &Live, entities: &[Vec<i32>], text: &mut String) -> Result<(), CadError> {
    let mut links = Vec::new();
    for (d, tags) in entities.iter().enumerate().take(3) {
        if !tags.is_empty() {
            links.extend(l.periodic(d as i32, tags)?.into_iter().map(|p| (d, p)));
        }
    }
    if links.is_empty() {
        return Ok(());
    }
    let _ = writeln!(text, "$Periodic\n{}", links.len());
    for (d, (slave, master, affine, pairs)) in &links {
        let _ = writeln!(text, "{d} {slave} {master}");
        let _ = write!(text, "{}", affine.len());
        affine.iter().for_each(|a| {
            let _ = write!(text, " {a:?}");
        });
        let _ = writeln!(text, "\n{}", pairs.len());
        for (s, m) in pairs {
            let _ = writeln!(text, "{s} {m}");
        }
    }
    text.push_str("$EndPeriodic\n");
    Ok(())
}

/// What [`write_back`] did.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct WrittenBack {
    /// Elements of the model made of order p and given their curved nodes.
    pub elements: usize,
    /// Nodes moved to the curved mesh's places.
    pub nodes: usize,
}

/// Puts `curved`, the curved mesh of the live model's linear mesh (every
/// element of it, of the same tags), into the model: its nodes and
/// elements of order `p`, on the same entities, so that physical groups,
/// classification and every Gmsh writer see the curved mesh. Without
/// periodic links by [`put`], with them by Gmsh's own `setOrder`
/// ([`by_set_order`]), which links the new nodes of periodic entities.
pub fn write_back(library: &Path, curved: &Layout, p: usize) -> Result<WrittenBack, CadError> {
    with_live(library, |l| if curved.periodic.is_empty() { put(l, curved) } else { by_set_order(l, curved, p) })
}

/// [`write_back`] through Gmsh's `setOrder` (its optimiser, incomplete
/// elements and messages but errors off for the call, the user's options
/// restored: the numbering is what the user's own `setOrder` gives; its
/// periodic links of the new nodes are Gmsh's own), every node then moved
/// to its place and the nodes on curves and surfaces given their
/// parameters there.
///
/// Why by position: `setOrder` may renumber nodes and elements
/// (`Mesh.Renumber`), but it keeps each entity's nodes and each entity's
/// elements of a kind in their order, the new nodes after the old. Each
/// old node is checked to be where it was, and each element's corners to
/// be its old corners.
fn by_set_order(l: &Live, curved: &Layout, p: usize) -> Result<WrittenBack, CadError> {
    {
        let entities: Vec<(i32, i32)> = (0..=3).map(|d| l.s.entities(d)).collect::<Result<Vec<_>, _>>()?.concat();
        let before: Vec<_> = entities.iter().map(|&(d, t)| Ok((l.nodes(d, t)?, l.elements(d, t)?))).collect::<Result<_, CadError>>()?;
        // Gmsh's verbosity to errors only: its report of its own
        // placement's distortion is not of the mesh the user gets
        let saved: Vec<(&str, f64)> = ["Mesh.HighOrderOptimize", "Mesh.SecondOrderIncomplete", "General.Verbosity"]
            .into_iter()
            .map(|o| l.option(o).map(|v| (o, v)))
            .collect::<Result<_, _>>()?;
        saved.iter().try_for_each(|(o, v)| l.s.set_option(o, if *o == "General.Verbosity" { v.min(1.0) } else { 0.0 }))?;
        let clock = std::time::Instant::now();
        let ordered = l.set_order(p);
        tracing::info!("Gmsh's setOrder({p}): {:.3}s", clock.elapsed().as_secs_f64());
        saved.iter().try_for_each(|(o, v)| l.s.set_option(o, *v))?;
        ordered?;
        let changed = |what: String| CadError::Gmsh {
            call: "deformesh.gmsh.curve".into(),
            message: format!("{what}: the model's mesh changed during the run"),
        };
        // old node tag → new node tag, old element tag → its new nodes
        let mut node = std::collections::HashMap::new();
        let mut element: std::collections::HashMap<usize, Vec<usize>> = std::collections::HashMap::new();
        for (&(d, t), ((old_tags, old_xyz), old_blocks)) in entities.iter().zip(&before) {
            let (new_tags, new_xyz) = l.nodes(d, t)?;
            if new_tags.len() < old_tags.len() || new_xyz[..old_xyz.len()] != old_xyz[..] {
                return Err(changed(format!("the nodes of entity ({d}, {t}) moved")));
            }
            node.extend(old_tags.iter().copied().zip(new_tags.iter().copied()));
            let new_blocks = l.elements(d, t)?;
            for ((old_type, old_el, _), (new_type, _, new_nodes)) in old_blocks.iter().zip(&new_blocks) {
                let same_kind = shape_of(*old_type as i64).zip(shape_of(*new_type as i64)).is_some_and(|(a, b)| a.0 == b.0);
                if !same_kind || new_nodes.len() % old_el.len().max(1) != 0 {
                    return Err(changed(format!("the elements of entity ({d}, {t})")));
                }
                let per = new_nodes.len() / old_el.len().max(1);
                element.extend(old_el.iter().enumerate().map(|(k, &tag)| (tag, new_nodes[k * per..(k + 1) * per].to_vec())));
            }
        }
        let mut place: std::collections::HashMap<usize, [f64; 3]> = std::collections::HashMap::new();
        let mut done = WrittenBack::default();
        for e in &curved.elements {
            let Some(theirs) = element.get(&(e.tag as usize)) else {
                return Err(changed(format!("element {} is not in the model", e.tag)));
            };
            let perm = gmsh_perm(e.shape, e.order);
            if theirs.len() != perm.len() {
                return Err(changed(format!("element {} has {} nodes in Gmsh and {} in the curved mesh", e.tag, theirs.len(), perm.len())));
            }
            for (ours, &local) in perm.iter().enumerate() {
                let n = e.nodes[ours];
                if local < e.shape.num_nodes(1) && node.get(&(curved.node_tags[n] as usize)) != Some(&theirs[local]) {
                    return Err(changed(format!("element {}: its corner {local} is not the curved mesh's node {}", e.tag, curved.node_tags[n])));
                }
                place.insert(theirs[local], curved.coords[n]);
            }
            done.elements += 1;
        }
        let clock = std::time::Instant::now();
        set_nodes(l, &place)?;
        tracing::info!("{} nodes set: {:.3}s", place.len(), clock.elapsed().as_secs_f64());
        done.nodes = place.len();
        Ok(done)
    }
}

/// [`write_back`] without `setOrder` (which costs as much as a third of
/// the curving, measured on 94,286 tets at p = 2): the curved mesh's new
/// nodes added on their entities with their parameters, its moved nodes
/// moved, and each element replaced by its curved one of the same tag.
/// The new nodes keep the curved mesh's tags (after the model's largest),
/// as in the file `deformesh curve` writes.
fn put(l: &Live, curved: &Layout) -> Result<WrittenBack, CadError> {
    let clock = std::time::Instant::now();
    let (tags, xyz) = l.nodes(-1, -1)?;
    let had: std::collections::HashMap<usize, &[f64]> = tags.iter().copied().zip(xyz.chunks_exact(3)).collect();
    // per entity: the nodes to add, and the nodes of the model to move
    let mut add: std::collections::BTreeMap<(i32, i32), Vec<usize>> = Default::default();
    let mut moved: std::collections::HashMap<usize, [f64; 3]> = Default::default();
    for (i, &tag) in curved.node_tags.iter().enumerate() {
        match had.get(&(tag as usize)) {
            None => add.entry((curved.node_entity[i].0 as i32, curved.node_entity[i].1 as i32)).or_default().push(i),
            Some(x) if **x != curved.coords[i][..] => {
                moved.insert(tag as usize, curved.coords[i]);
            }
            Some(_) => {}
        }
    }
    for (&(d, t), nodes) in &add {
        let flat: Vec<f64> = nodes.iter().flat_map(|&i| curved.coords[i]).collect();
        let c2 = std::time::Instant::now();
        let uv = if (1..=2).contains(&d) { l.s.parametrization(d, t, &flat)? } else { Vec::new() };
        tracing::debug!("parametrization of {} nodes on ({d}, {t}): {:.3}s", nodes.len(), c2.elapsed().as_secs_f64());
        let tags: Vec<usize> = nodes.iter().map(|&i| curved.node_tags[i] as usize).collect();
        l.add_nodes((d, t), &tags, &flat, &uv)?;
    }
    tracing::info!("nodes added: {:.3}s", clock.elapsed().as_secs_f64());
    set_nodes(l, &moved)?;
    tracing::info!("nodes moved: {:.3}s", clock.elapsed().as_secs_f64());
    // by (dim, entity, type): the element tags and their nodes' tags
    let mut blocks: std::collections::BTreeMap<(i32, i32, i64), Tagged> = std::collections::BTreeMap::new();
    let mut done = WrittenBack {
        elements: 0,
        nodes: add.values().map(Vec::len).sum::<usize>() + moved.len(),
    };
    for e in curved.elements.iter().filter(|e| e.shape.dim() > 0) {
        let block = blocks.entry((e.shape.dim() as i32, e.entity as i32, msh_type(e.shape, e.order))).or_default();
        block.0.push(e.tag as usize);
        let mut local = vec![0; e.nodes.len()];
        for (ours, &g) in gmsh_perm(e.shape, e.order).iter().enumerate() {
            local[g] = curved.node_tags[e.nodes[ours]] as usize;
        }
        block.1.extend(local);
        done.elements += 1;
    }
    // every element of the model is in the curved mesh: each entity's
    // are removed whole (by their tags, Gmsh's search costs ~1 s here)
    let entities: std::collections::BTreeSet<(i32, i32)> = blocks.keys().map(|k| (k.0, k.1)).collect();
    entities.iter().try_for_each(|&e| l.clear_elements(e))?;
    tracing::info!("elements removed: {:.3}s", clock.elapsed().as_secs_f64());
    for ((_, t, ty), (tags, nodes)) in &blocks {
        l.add_elements(*t, *ty, tags, nodes)?;
    }
    tracing::info!("{} nodes added or moved, {} elements replaced: {:.3}s", done.nodes, done.elements, clock.elapsed().as_secs_f64());
    Ok(done)
}

/// Moves each node to its place, with its parameters on the curve or
/// surface it is classified on.
fn set_nodes(l: &Live, place: &std::collections::HashMap<usize, [f64; 3]>) -> Result<(), CadError> {
    if place.is_empty() {
        return Ok(());
    }
    for d in 0..=3 {
        for (_, t) in l.s.entities(d)? {
            let (tags, _) = l.nodes(d, t)?;
            let here: Vec<(usize, [f64; 3])> = tags.iter().filter_map(|n| place.get(n).map(|x| (*n, *x))).collect();
            let uv = if (1..=2).contains(&d) && !here.is_empty() {
                let flat: Vec<f64> = here.iter().flat_map(|h| h.1).collect();
                l.s.parametrization(d, t, &flat)?
            } else {
                Vec::new()
            };
            let k = if uv.is_empty() { 0 } else { d as usize };
            for (i, (n, x)) in here.iter().enumerate() {
                l.set_node(*n, x, &uv[i * k..(i + 1) * k])?;
            }
        }
    }
    Ok(())
}
