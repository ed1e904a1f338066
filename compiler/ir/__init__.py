"""eomc.compiler.ir"""
