# (filled when the module's tests land)
