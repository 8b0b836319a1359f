"""The one thing pyproject.toml cannot say without an experimental table: the compiled part.

``flexhrc.representation.formats._andor_fast`` is the ANDOR text reader's common case in C (a
few hundred lines, no library): a graph loads 1.5–2x faster in a fresh process. It is
optional: without a C compiler the install goes on and the pure-Python reader (the reference,
always tested) does all the reading.
"""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension(
            "flexhrc.representation.formats._andor_fast",
            ["src/flexhrc/representation/formats/_andor_fast.c"],
            extra_compile_args=["-O2"],
            optional=True,
        )
    ]
)
