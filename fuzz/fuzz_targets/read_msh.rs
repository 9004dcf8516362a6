//! Any bytes into every MSH reader: a result or an error, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = deformesh::io::msh::parse_msh(data);
    let _ = deformesh::io::msh::parse_hex_msh(data);
    let _ = deformesh::mesh::CurvedMesh::<2>::parse_msh(data);
    let _ = deformesh::mesh::CurvedMesh::<3>::parse_msh(data);
    let _ = deformesh::io::msh::parse_any(data, false);
});
