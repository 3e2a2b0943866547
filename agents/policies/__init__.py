"""The policies room: trained policies as files — loading one by name or path
(:mod:`~agents.policies.loading`), the manifest and weights-only reading
(:mod:`~agents.policies.policy_io`, :mod:`~agents.policies.policy_zip`), the pretrained ones
(:mod:`~agents.policies.pretrained`) and the export as an FMU or ONNX
(:mod:`~agents.policies.policy_fmu`, :mod:`~agents.policies.residual_export`).

Import each name from its module.
"""
