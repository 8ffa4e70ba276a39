"""Puppet: shadow puppets (an armature, cut-out parts and control rods in the picture plane)
whose rods drive the bones by planar IK, solved live and baked to keys, and the Shadow Theatre
scene preset."""
