"""Shared parts of Penumbra's Python tools (penumbra-tune; the bench and the extremes matrix are
to move here): where the build's tools are, scene files read with tomllib and patched in place,
one measured point (penumbra-view's GPU timings and penumbra-reference's metrics), and Pareto
frontiers. The scripts in tools/ are thin entry points that put tools/ on sys.path."""
