r"""Inverse dynamics: open chains, closed and complex chains, from a mechanism's inertials.

Owns park's closed-form planar 2-link arm and recursive Newton-Euler for chains
(``open_chain``), Newton-Euler on the spanning tree of a closed chain projected onto the
independent joints by virtual work (``closed_chain``), and the inertial parameters read from a
:class:`~mechkin.model.Mechanism` (``from_mechanism``).

May import: ``mechkin.model``, ``mechkin.spatial``, ``mechkin.errors``; no other solver room.
"""
