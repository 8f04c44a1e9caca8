"""Running cases: the case protocol (``case``), one case run with its flags, variants and summary
(``runner``), validation against references, and studies (a case over a grid of flags, on a Dask
cluster, into one table), with the built-in studies in ``builtin`` and what cases and studies
compare against (a paper's parameters, laws and values) in ``references``.

Cases (``mpmdem.cases``) build on this layer; it finds them by name (``mpmdem.cases.CASES``) and
never imports one by module path.
"""
