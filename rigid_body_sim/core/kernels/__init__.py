"""Every compiled (numba) module of the core, and nothing else: the only sources the kernel cache depends on.

``jit.py`` holds the compile options and the rule they need, and drops numba's cached machine
code when any file under this folder changes (and only then: an edit elsewhere in the core
never recompiles). ``layout.py`` names the columns of the buffers; ``rotation``, ``forces``,
``dynamics``, ``integrators``, ``reduced_models`` and ``sensors`` are the per-body functions,
``stepping`` the loop over bodies and steps (``single_step`` its one-argument entry point for
``step(1)``, ``parallel`` its multi-threaded form), ``compile`` the install-time
:func:`~rigid_body_sim.core.kernels.compile.compile_kernels`. Modules here import only each
other, numpy, numba and the standard library (test_core_purity.py checks it), so that the
folder's hash covers everything the compiled code is built from.
"""
