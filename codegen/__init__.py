"""Turning an estimator into C: CasADi's CodeGenerator for the numeric kernel, jinja2 templates
for the public header and API, one function that writes (or checks) a generated folder."""
