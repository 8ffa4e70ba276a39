"""Motion: Add Motion keys a head shake, walk or run from the roles the Rust core finds in the
bones, and Make Video renders the frame range to an MP4. ``operators`` holds the operators;
``planning`` (the core's motion), ``keying`` (keys written) and ``filming`` (camera, light,
render) the work they do."""
