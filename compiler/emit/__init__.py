"""eomc.compiler.emit"""
