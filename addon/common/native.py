"""The one door to the Rust core: the add-on's modules get the native module
(``miniskeleton_core``, the wheel the extension bundles for its platform) from here, imported
when first called so that registering the add-on never loads it."""


def core():
    """The ``miniskeleton_core`` module."""
    import miniskeleton_core

    return miniskeleton_core
