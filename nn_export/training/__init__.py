"""What only a training machine runs: the situation sampler, the GPC labels (CasADi),
datasets on disk (their spec and shards, the resumable writer, on-policy rounds), training
and export (torch, onnx) and the network's benchmark rows. It imports
:mod:`nn_export.runtime`, never the reverse; nothing is imported here.

Rooms: ``sampler`` (random situations), ``two_pass`` (the paper's two-pass distribution),
``labels`` (the GPC's answers), ``ties`` (near ties between passing left and right), ``dataset/``
(``spec``: what decides a dataset; ``shards``: its files; ``labelling``: situations into
shard arrays; ``writer``: the resumable ``generate``; ``onpolicy``: DAgger/DART rounds),
``train`` (torch), ``export`` (ONNX), ``bench_rows`` (the network's benchmark rows).
"""
