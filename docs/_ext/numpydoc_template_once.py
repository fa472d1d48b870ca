"""numpydoc with its docstring template compiled once per build.

numpydoc's ``get_doc_object`` makes a new Jinja environment and compiles its template
``numpydoc_docstring.rst`` for every docstring and every signature it renders: about 6 500
times for this site, a quarter of the build's time.  This extension registers numpydoc
(through the ``get_doc_object_`` argument of :func:`numpydoc.numpydoc.setup`, numpydoc's own
hook for this) with a ``get_doc_object`` that compiles the same template from the same
loader once per builder and hands it over; the rendered pages are the same.

Use ``"numpydoc_template_once"`` in ``extensions`` instead of ``"numpydoc"``.
"""

from __future__ import annotations

import os
from typing import Any

from jinja2 import FileSystemLoader, Template
from jinja2.sandbox import SandboxedEnvironment
from numpydoc import docscrape, docscrape_sphinx, numpydoc
from sphinx.jinja2glue import BuiltinTemplateLoader

_TEMPLATE_DIRS = [os.path.join(os.path.dirname(docscrape_sphinx.__file__), "templates")]


def _template(builder: Any) -> Template:
    """numpydoc's docstring template, loaded as its ``get_doc_object`` loads it."""
    if builder is not None:
        loader: Any = BuiltinTemplateLoader()
        loader.init(builder, dirs=_TEMPLATE_DIRS)
    else:
        loader = FileSystemLoader(_TEMPLATE_DIRS)
    return SandboxedEnvironment(loader=loader).get_template("numpydoc_docstring.rst")


def setup(app: Any) -> dict[str, Any]:
    """Register numpydoc with a ``get_doc_object`` that reuses one compiled template."""
    templates: dict[int, tuple[Any, Template]] = {}

    def get_doc_object(obj: Any, what: str | None = None, doc: Any = None,
                       config: dict[str, Any] | None = None, builder: Any = None) -> Any:
        config = {} if config is None else config
        held = templates.get(id(builder))
        if held is None or held[0] is not builder:
            held = templates[id(builder)] = (builder, _template(builder))
        config["template"] = held[1]
        return docscrape.get_doc_object(
            obj, what=what, doc=doc, config=config,
            class_doc=docscrape_sphinx.SphinxClassDoc,
            func_doc=docscrape_sphinx.SphinxFunctionDoc,
            obj_doc=docscrape_sphinx.SphinxObjDoc,
        )

    return numpydoc.setup(app, get_doc_object_=get_doc_object)
