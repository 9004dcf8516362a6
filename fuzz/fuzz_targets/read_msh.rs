//! Any bytes into every MSH reader: a result or an error, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = deformesh::io::msh::msh_text(data).unwrap_or_else(|_| String::from_utf8_lossy(data).into_owned());
    let _ = deformesh::io::msh::parse_msh(&text);
    let _ = deformesh::io::msh::parse_hex_msh(&text);
    let _ = deformesh::io::curved::CurvedMesh::<2>::parse_msh(&text);
    let _ = deformesh::io::curved::CurvedMesh::<3>::parse_msh(&text);
    let _ = deformesh::io::msh::cell_type_of(&text);
});
