//! The 3D boundary model (faces, edges, corners of a hex mesh).
