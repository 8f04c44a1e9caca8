"""Published references that cases and studies compare against: a paper's parameters, laws and
measured values, with the readings that make a run comparable to them (SI units).

Cases (``mpmdem.cases``) and the built-in studies (``mpmdem.study.builtin``) both import these, so a
study never reaches into a case module for a paper's number.
"""
