"""Serving a plotter to a browser: Jupyter views, the remote (server-rendered) view, web security, the
file root the app confines paths to, and the lifetimes that release a view when its cell goes."""
