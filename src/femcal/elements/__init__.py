"""Element kernels: stiffness and mass of all elements of one type at once.

Conventions shared by every kernel
----------------------------------
* Pure functions of arrays: no deck, model or global state. Every physical input (modulus,
  thickness, density, area, section dimensions, spring rate) is an explicit argument, so the
  calibration can differentiate the same code with respect to it.
* Index letters in einsum and docstrings: ``e`` element, ``q`` quadrature point, ``a``/``b``
  node of the element, ``i``/``j`` direction, ``k``/``l`` element DOF.
* Coordinates are in the basic frame: ``xyz`` has shape ``(n_elem, n_nodes, 3)``.
* Element matrices are returned in the basic frame with shape ``(n_elem, n_dof, n_dof)``,
  DOF ordered node by node: ``[T1 T2 T3 R1 R2 R3]`` per node for elements with rotations
  (bars, beams, shells, bushes), ``[T1 T2 T3]`` per node for solids. The assembly rotates them
  to each node's displacement (CD) frame and scatters them into the g-set.
* Units are the model's, whatever its deck or builder used (femcal's models: mm, tonne, s, N,
  MPa); kernels never convert.
* Constitutive matrices use NASTRAN's Voigt order: ``xx, yy, zz, xy, yz, zx`` for solids
  (engineering shear strains), ``xx, yy, xy`` for membranes and bending, ``xz, yz`` for
  transverse shear.
"""
