# ips-baro tests (being written).
