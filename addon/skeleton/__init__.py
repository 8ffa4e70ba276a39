"""Skeleton: Fit Skeleton to Mesh, the original rest pose kept and restored, and rig exchange
(NPZ bundle, debug JSON). ``operators`` holds the operators; ``fitting``, ``snapshot``,
``editing``, ``joints`` and ``exchange`` the work they do."""
