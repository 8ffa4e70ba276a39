"""Motion: Add Motion keys a head shake, walk or run from the roles the Rust core finds in the
bones, and Make Video renders the frame range to an MP4."""
