"""The thesis' self-supervised UV parameterisation (chapter 3).

``patchnet``  PatchNet: DiffusionNet soft assignment to K patches (losses eq. 3.1-3.2), face
              assignment by averaging and neighbour consolidation, island merging.
``uv_mlp``    forward (xyz + patch code -> uv) and backward (uv + code -> xyz) MLPs.
``losses``    eq. 3.1-3.3 and 3.6-3.8.
``train``     per-object training (PatchNet, then the UV MLPs), checkpoints.
``infer``     inference on any discretisation of the trained shape, packing with xatlas.
``method``    the ``neural`` entry of :func:`dressmeup.methods.uvparam.get_method`.
"""
